"""The envelope matrix's controller-dependent half, measured again: ``python -m bench.envelope_controller
[--workers N] [--out NAME]`` rewrites ``bench/results/envelope.json`` after a change of the controller (about
13 min on 2 workers here, against about 40 for the whole bench), or writes ``NAME.json`` beside it: a
candidate's figures next to the shipped ones, the shipped file untouched.

What depends on the controller is re-run for every condition of the existing envelope.json and the base
scene, on the same draws: each side's identification and gains, the telepresence session with them and its
figures, and the shipped gains' session on the same draw (the before-figure). What does not is kept as
measured, with the commit it was measured on (``pads_bounds_provenance``, ``render_provenance``,
``timing_provenance``): the three constant pads of each
condition (held skins against the direct touch: no controller in them), the optimal-current bounds of the
bound subset (the same), the render sweep (render mode: the telepresence changes this mode is run for do
not reach it; the bench's ``--render-only`` measures it again) and the 1-vs-2-worker timing. The summary
keys (``envelope_*``, ``base_*``, the failing conditions, the spread of each figure) are recomputed from the
new rows by the same functions as :mod:`bench.envelope_bench`, and the figures of the run they replace are
kept under ``previous_controller``, so the change is read in one file.
"""

from __future__ import annotations

import argparse
from typing import Any

from bench.common import current_results_dir, write_results
from bench.envelope_bench import plot
from bench.envelope_rerun import COMPARED, print_change, rerun_matrix
from telethermo.offline.envelope import Condition, run_condition

#: what a row keeps from the previous run: controller-independent (the constant pads)
KEPT = ("pads", "best_pad", "best_pad_headline_C")


def rerun(old_row: dict[str, Any]) -> dict[str, Any]:
    """One condition's controller-dependent figures again, its pads kept; ``beats_best_pad`` recomputed."""
    row = run_condition(Condition(**old_row["condition"]), with_pads=False, with_shipped=True)
    row.update({k: old_row[k] for k in KEPT})
    row["beats_best_pad"] = bool(row["headline_C"] < row["best_pad_headline_C"])
    return row


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m bench.envelope_controller", description=__doc__.split("\n")[0]
    )
    ap.add_argument("--workers", type=int, default=2, help="processes on this machine (default 2)")
    ap.add_argument(
        "--out", default="envelope", help="result name: bench/results/NAME.json and .png (default envelope)"
    )
    a = ap.parse_args(argv)
    run = rerun_matrix(rerun, a.workers)
    old, rows = run.old, run.rows
    out = {
        **old,
        **run.summary,
        "previous_controller": {k: old.get(k) for k in COMPARED}
        | {"provenance": old.get("provenance") or old.get("matrix_provenance")},
        "controller_wall_s": run.wall_s,
        "controller_rerun": "identified and shipped sessions of every condition re-run on this commit; pads, "
        "bounds, render sweep and worker timing kept from the commits their *_provenance keys name",
        "base": run.base,
        "conditions": rows,
    }
    # the sessions are this commit's (``provenance``, written by write_results); the render sweep and the
    # worker timing keep the commit they were measured on (bench/report.py reads them per key)
    out["render_provenance"] = old.get("render_provenance") or old.get("provenance")
    out["timing_provenance"] = (
        old.get("timing_provenance") or old.get("matrix_provenance") or old.get("provenance")
    )
    if "pads_provenance" in old:  # pads re-measured by bench.envelope_pads: theirs, and the bounds', kept
        out.pop("controller_provenance", None)  # the sessions are this run's now
    else:
        out["pads_bounds_provenance"] = (
            old.get("pads_bounds_provenance") or old.get("matrix_provenance") or old.get("provenance")
        )
    for k in ("matrix_provenance", "provenance"):
        out.pop(k, None)
    write_results(a.out, out)
    plot(run.scored, str(current_results_dir() / f"{a.out}.png"))
    print_change(old, out)
    print(
        f"failing conditions: {len(out['failing_conditions'])} of {len(rows)}; "
        f"wall {out['controller_wall_s']:.0f} s"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
