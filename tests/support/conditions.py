"""Envelope conditions the tests pin, from one data file (``pinned_conditions.json`` beside this module):
each was drawn by the envelope benchmark (or a fresh draw) and named a failure before the mend its test
checks; the file says where it was drawn and what failed there."""

from __future__ import annotations

import json
from pathlib import Path

from telethermo.offline.envelope import Condition

PINNED = Path(__file__).with_name("pinned_conditions.json")


def pinned_condition(name: str) -> Condition:
    """The pinned condition ``name`` (a key of the file's ``conditions``), exact as it was drawn."""
    table = json.loads(PINNED.read_text(encoding="utf-8"))["conditions"]
    if name not in table:
        raise KeyError(f"{PINNED}: conditions: no {name!r} (have {', '.join(sorted(table))})")
    return Condition.from_json(table[name]["condition"])
