"""What the envelope's candidate experiments share (bench/envelope_probe_flux.py,
bench/envelope_virtual_finger.py): their command-line options for the matrix, the shipped run they are scored
against and one condition's row."""

from __future__ import annotations

import argparse
import json
from typing import Any

from bench.common import RESULTS_DIR
from telethermo.offline import envelope

ONLY_HELP = "comma-separated condition indices (default: the whole matrix)"


def add_matrix_args(ap: argparse.ArgumentParser, only_help: str = ONLY_HELP) -> None:
    """``--workers``, ``--shipped`` (the shipped run's results) and ``--only``."""
    ap.add_argument("--workers", type=int, default=2, help="processes (default 2)")
    ap.add_argument("--shipped", default=str(RESULTS_DIR / "envelope.json"), help="the shipped run's results")
    ap.add_argument("--only", help=only_help)


def load_shipped(path: str) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """The shipped run's results and its scored conditions (those with a headline)."""
    with open(path, encoding="utf-8") as f:
        run = json.load(f)
    return run, [c for c in run["conditions"] if "headline_C" in c]


def only(shipped: list[dict[str, Any]], want: set[int]) -> list[dict[str, Any]]:
    """The shipped conditions whose index is in ``want``."""
    return [c for c in shipped if c["condition"]["index"] in want]


def condition_row(cond: dict[str, Any], keep: tuple[str, ...] = envelope.SHIPPED_KEYS) -> dict[str, Any]:
    """One condition (its parameters as in envelope.json) run without the pads: its index, the figures
    ``keep``, whether a cut lasted the session, and the number of trips."""
    c = envelope.Condition.from_json(cond)
    r = envelope.run_condition(c, with_pads=False)
    return {
        "index": c.index,
        **{k: r[k] for k in keep},
        "session_long_cut": r["session_long_cut"],
        "trips": len(r["trips"]),
    }
