"""The envelope on a held-out draw: ``python -m bench.envelope_heldout_bench [--quick] [--workers N]`` writes
``bench/results/envelope_heldout.json``.

The matrix (bench/envelope_bench.py, seed 22_2026) has been looked at for many sessions: changes were kept or
dropped by what they did to it, so its figures flatter whatever was chosen on it. A draw nobody has looked at
says whether they hold: :data:`HELDOUT_N` Latin-hypercube conditions of the same envelope from
:data:`HELDOUT_SEED` (no corners: the matrix's corners are the same points whatever the seed), each scored as
the matrix scores its conditions (identified gains, the three constant pads; not the shipped gains'
before-figure), summarised by the same function, with the matrix's figures copied beside for reading in one
file (``matrix``). Nothing may be tuned on this seed: a change chosen by what it does here needs a new one.
"""

from __future__ import annotations

import argparse
import functools
import json
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from bench.common import current_results_dir, write_results
from bench.envelope_bench import safe_score, summarise
from telethermo.offline.envelope import base_condition, draw_conditions

#: the held-out draw's seed: used for nothing else (the matrix 22_2026, the tuner 7, the guard's lead 4242)
HELDOUT_SEED = 30_2026
HELDOUT_N, HELDOUT_N_QUICK = 100, 1
#: the keys compared with the matrix's (the matrix's value copied from envelope.json under ``matrix``)
COMPARED = (
    "envelope_n_conditions",
    "envelope_oscillating_conditions",
    "envelope_session_long_cuts",
    "envelope_unexpected_trips",
    "envelope_skin_past_clamp_worst_C",
    "envelope_clamp_reached_fraction",
    "envelope_beats_best_pad_fraction",
    "envelope_cue_order_kept_fraction",
)


def run(*, quick: bool = False, workers: int = 2) -> dict[str, Any]:
    """Score the held-out draw and write envelope_heldout.json beside envelope.json."""
    t0 = time.perf_counter()
    conds = draw_conditions(HELDOUT_N_QUICK if quick else HELDOUT_N, HELDOUT_SEED, corners=False)
    with ProcessPoolExecutor(max_workers=workers) as ex:
        score = functools.partial(safe_score, with_shipped=False)  # the constant pads, not the before-figure
        fut_base = ex.submit(score, base_condition())
        rows = list(ex.map(score, conds))
        base = fut_base.result()
    matrix_path = current_results_dir() / "envelope.json"
    matrix = json.loads(matrix_path.read_text(encoding="utf-8")) if matrix_path.exists() else {}
    out = {
        "quick": quick,
        "seed": HELDOUT_SEED,
        **summarise(rows, base),
        "matrix": {k: matrix.get(k) for k in COMPARED} | {"seed": matrix.get("seed")},
        "wall_s": time.perf_counter() - t0,
        "workers": workers,
        "conditions": rows,
    }
    write_results("envelope_heldout", out)
    print(f"{'held-out draw (seed ' + str(HELDOUT_SEED) + ')':40s} {'held out':>10s} {'matrix':>10s}")
    for k in COMPARED:
        print(f"{k:40s} {_fmt(out[k]):>10s} {_fmt(out['matrix'][k]):>10s}")
    print(f"failing conditions: {len(out['failing_conditions'])} of {len(rows)}; wall {out['wall_s']:.0f} s")
    return out


def _fmt(v: Any) -> str:
    return f"{v:.4g}" if isinstance(v, float) else str(v)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m bench.envelope_heldout_bench", description=__doc__.split("\n")[0]
    )
    ap.add_argument("--quick", action="store_true", help=f"{HELDOUT_N_QUICK} condition (CI)")
    ap.add_argument("--workers", type=int, default=2, help="processes on this machine (default 2)")
    a = ap.parse_args(argv)
    run(quick=a.quick, workers=a.workers)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
