"""The envelope matrix's constant pads, measured again: ``python -m bench.envelope_pads [--workers N]``
rewrites the pads of ``bench/results/envelope.json`` after a change of the pad baseline
(telethermo.offline.envelope.hold_skin), in about a quarter of the whole bench's time.

Each condition of the existing file (and the base scene) is run again with the shipped gains, which gives its
direct touch (the same whatever the controller) and, by :func:`~telethermo.offline.envelope.run_condition`'s
own code, its three constant pads and the pad held at a clamp the direct touch passes. The row keeps its
controller's figures; ``pads``, ``best_pad``, ``best_pad_headline_C``, ``clamp_short_pad_C`` and
``beats_best_pad`` are replaced, and the summary keys are recomputed by :mod:`bench.envelope_bench`'s
functions. The figures of the run they replace are kept under ``previous_pads``, with the conditions whose
best pad moved, so the change is read in one file. Provenance: ``pads_provenance`` (this run),
``controller_provenance`` (the sessions, kept), ``bounds_provenance`` (the optimal-current bounds, kept).
"""

from __future__ import annotations

import argparse
from typing import Any

from bench.common import current_results_dir, write_results
from bench.envelope_bench import plot
from bench.envelope_rerun import COMPARED, print_change, rerun_matrix
from telethermo.offline.envelope import Condition, run_condition
from telethermo.provenance import provenance

#: what a pad run replaces in a row
PAD_KEYS = ("pads", "best_pad", "best_pad_headline_C", "clamp_short_pad_C")
#: a best pad that moved by more than this, °C, is listed
MOVED_C = 1e-6


def repad(old_row: dict[str, Any]) -> dict[str, Any]:
    """One condition's pads again (its controller's figures kept); ``beats_best_pad`` recomputed."""
    fresh = run_condition(Condition(**old_row["condition"]), gains="shipped", with_pads=True)
    row = {**old_row, **{k: fresh[k] for k in PAD_KEYS}}
    row["beats_best_pad"] = bool(row["headline_C"] < row["best_pad_headline_C"])
    return row


def moved(old: list[dict[str, Any]], new: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The conditions whose best pad changed: index, best pad before and after, °C, ours, and whether ours
    still beats it."""
    return [
        {
            "index": n["condition"]["index"],
            "best_pad_before_C": o["best_pad_headline_C"],
            "best_pad_C": n["best_pad_headline_C"],
            "headline_C": n["headline_C"],
            "beats_best_pad": n["beats_best_pad"],
        }
        for o, n in zip(old, new)
        if abs(o["best_pad_headline_C"] - n["best_pad_headline_C"]) > MOVED_C
    ]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.envelope_pads", description=__doc__.split("\n")[0])
    ap.add_argument("--workers", type=int, default=2, help="processes on this machine (default 2)")
    a = ap.parse_args(argv)
    run = rerun_matrix(repad, a.workers)
    old = run.old
    out = {
        **old,
        **run.summary,
        "previous_pads": {k: old.get(k) for k in COMPARED} | {"moved": moved(run.old_scored, run.scored)},
        "pads_wall_s": run.wall_s,
        "base": run.base,
        "conditions": run.rows,
    }
    out["bounds_provenance"] = old.get("pads_bounds_provenance") or old.get("bounds_provenance")
    out["controller_provenance"] = old.get("controller_provenance") or old.get("provenance")
    out["pads_provenance"] = provenance()
    out.pop("pads_bounds_provenance", None)
    write_results("envelope", out)
    plot(run.scored, str(current_results_dir() / "envelope.png"))
    print_change(old, out)
    n_moved = len(out["previous_pads"]["moved"])
    print(f"best pad moved in {n_moved} of {len(run.scored)}; wall {run.wall_s:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
