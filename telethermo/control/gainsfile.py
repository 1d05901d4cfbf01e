"""The gains file the nodes load (``--gains FILE``): format, validation, atomic write.

    {"format": "telethermo.gains/1", "period_s": 0.01,
     "master": {"kp_A_per_C": 1.66, ...}, "slave": {...}, ...}        (docs/tuning.md)

``default_params(role, **load_gains(path)[role])`` gives the tuned parameters. ``"apply"``
(:func:`apply_marks`) says which keys a running node takes by SDO and which need a restart. Other keys (the
tuner's objective and search, see :func:`telethermo.tuning.document.gains_document`) are kept for
the record and ignored here.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any, cast

from telethermo.atomic import write_json_atomic
from telethermo.control.gain_fields import GAIN_FIELDS, RESTART_GAIN_FIELDS, SDO_GAIN_FIELDS
from telethermo.control.params import default_params
from telethermo.control.types import Role

GAINS_FORMAT = "telethermo.gains/1"


def apply_marks() -> dict[str, Any]:
    """The gains file's ``"apply"`` entry: which of its keys ``telethermo apply-gains`` (or ``set``) can write
    to a running node, which need a node start with ``--gains FILE``, and the mode they are gains of."""
    return {"mode": "telepresence", "sdo": list(SDO_GAIN_FIELDS), "restart": list(RESTART_GAIN_FIELDS)}


def parse_gains(doc: Any, where: str = "gains") -> dict[Role, dict[str, float]]:
    """Validate a gains document -> {Role: {CoreParams field: value}} (the overrides of default_params)."""
    if not isinstance(doc, dict) or doc.get("format") != GAINS_FORMAT:
        raise ValueError(f'{where}: expected a JSON object with "format": "{GAINS_FORMAT}"')
    out: dict[Role, dict[str, float]] = {}
    for role in (Role.MASTER, Role.SLAVE):
        r = doc.get(role)
        if not isinstance(r, dict):
            raise ValueError(f"{where}: {role}: expected an object of gains")
        vals: dict[str, float] = {}
        for k, v in r.items():
            if k not in GAIN_FIELDS:
                raise ValueError(
                    f"{where}: {role}.{k}: unknown gain (expected one of {', '.join(GAIN_FIELDS)})"
                )
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ValueError(f"{where}: {role}.{k}: expected a finite number, got {v!r}")
            vals[k] = float(v)
        # CoreParams validates the ranges (ValueError names the field)
        default_params(role, **cast(dict[str, Any], vals))
        out[role] = vals
    return out


def load_gains(path: str | os.PathLike[str]) -> dict[Role, dict[str, float]]:
    """Read a gains file: ``default_params(role, **load_gains(path)[role])`` gives the tuned parameters."""
    p = Path(path)
    try:
        doc = json.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ValueError(f"{p}: no such gains file") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"{p}: not a JSON gains file ({exc})") from None
    return parse_gains(doc, str(p))


def write_gains(path: str | os.PathLike[str], doc: dict[str, Any]) -> Path:
    """Write a gains document atomically (validated first)."""
    parse_gains(doc, str(path))
    return write_json_atomic(path, doc)
