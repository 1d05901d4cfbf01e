"""Did the bound's search find the optimum? The clamped bound with a second start, on the rigs where the
search can stop short: ``python -m bench.envelope_bound_restart [--workers N]`` writes
``bench/results/envelope_bound_restart.json``.

The heat a TEM puts into its pad, αIT − ½I²R, is concave in the current: past the cooling peak αT/R more
cooling current warms. On a module whose peak lies inside the current limit (a high resistance, a weak Seebeck
coefficient) the bound's problem is not convex. Its early stage starts from the last pre-touch current; when
that is a strong cooling current and the skin must then warm, the search can warm by Joule heat alone and
stop on the limit, a local optimum, where a positive current warms far better (condition 28 from the
display's own state: the skin left at 11.7 °C against the 14.5 °C clamp, at −3.26 A). The bound is then not
the optimum, and every figure that leans on it (the clamped bound beats the pad, the ratio to it, the captured
share) is too kind to the controller there.

This runs the clamped bound of bench.envelope_bound_clamped (matched start, clamps [14.5, 43.5] °C) twice on
every matrix condition whose master module's peak at a 0 °C plate lies inside 0.8·I_max
(telethermo.offline.bound.cooling_peak_A): once as the other benches do, once with each stage's search also
started from 0 A (``restarts_A=(0.0,)``), the lower objective kept. Keys: ``restart_n_conditions``,
``restart_lowered`` (conditions whose bound fell by more than :data:`LOWERED_C`), the median and worst fall,
the clamped bound's beats-pad fraction over the whole matrix with the restarted values in place
(``restart_clamped_beats_best_pad_fraction`` beside ``single_clamped_beats_best_pad_fraction``),
``restart_newly_won`` (conditions the pad beat the single start and the restart beats), the median ratio
ours / bound on these conditions both ways, the skin's worst excursion past the clamps both ways, and
``single_vs_stored_max_C``: the single start against envelope_bound_clamped.json where it ran (0: the same
code gives the same bound).
"""

from __future__ import annotations

import argparse
import json
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np

from bench.common import current_results_dir, write_results
from bench.envelope_bench import bound_of
from bench.envelope_bound_clamped import CLAMP_C
from telethermo import sim
from telethermo.offline.bound import cooling_peak_A
from telethermo.offline.envelope import Condition, condition_scene

#: a bound that falls by more than this, °C, counts as lowered by the restart
LOWERED_C = 0.01


def peak_and_limit(c: Condition) -> tuple[float, float]:
    """The master module's cooling peak at a 0 °C plate and its current limit, 0.8·I_max, A."""
    sc, _ = condition_scene(c)
    rig = sim.build_rig(sc, "master", noise=False)
    return cooling_peak_A(float(np.max(rig._alpha)), float(np.max(rig._R)), 0.0), 0.8 * rig.I_max_A


def both(cond: dict[str, Any]) -> dict[str, Any]:
    """The clamped bound of one condition with one start and with the restart from 0 A, °C."""
    c = Condition.from_json(cond)
    one = bound_of(c, CLAMP_C)
    two = bound_of(c, CLAMP_C, restarts_A=(0.0,))
    return {
        "index": c.index,
        "single_C": one["bound_headline_C"],
        "restart_C": two["bound_headline_C"],
        "single_excess_C": one["clamp_excess_max_C"],
        "restart_excess_C": two["clamp_excess_max_C"],
    }


def summary(rows: list[dict[str, Any]], clamped: dict[int, dict[str, Any]]) -> dict[str, Any]:
    """The restart's effect on these conditions and on the matrix's clamped-bound figures."""
    drop = np.array([r["single_C"] - r["restart_C"] for r in rows])
    k = int(np.argmax(drop))
    after = {r["index"]: r["restart_C"] for r in rows}
    pad = {i: a["best_pad_headline_C"] for i, a in clamped.items()}
    single_wins = {i for i, a in clamped.items() if a["clamped_bound_headline_C"] < pad[i]}
    restart_wins = {i for i, a in clamped.items() if after.get(i, a["clamped_bound_headline_C"]) < pad[i]}
    ran = [r for r in rows if clamped[r["index"]]["clamped_bound_run"]]
    ratio = lambda key: float(  # noqa: E731
        np.median([clamped[r["index"]]["headline_C"] / r[key] for r in rows])
    )
    return {
        "restart_n_conditions": len(rows),
        "restart_lowered": [
            {"index": r["index"], "drop_C": r["single_C"] - r["restart_C"]}
            for r in rows
            if r["single_C"] - r["restart_C"] > LOWERED_C
        ],
        "restart_median_drop_C": float(np.median(drop)),
        "restart_max_drop_C": float(drop[k]),
        "restart_max_drop_condition": rows[k]["index"],
        "restart_raised_max_C": float(max(0.0, -drop.min())),
        "single_clamped_beats_best_pad_fraction": len(single_wins) / len(clamped),
        "restart_clamped_beats_best_pad_fraction": len(restart_wins) / len(clamped),
        "restart_newly_won": sorted(restart_wins - single_wins),
        "median_ratio_to_single_bound": ratio("single_C"),
        "median_ratio_to_restart_bound": ratio("restart_C"),
        "single_excess_worst_C": max(r["single_excess_C"] for r in rows),
        "restart_excess_worst_C": max(r["restart_excess_C"] for r in rows),
        "single_vs_stored_max_C": max(
            (abs(r["single_C"] - clamped[r["index"]]["clamped_bound_headline_C"]) for r in ran), default=None
        ),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m bench.envelope_bound_restart", description=__doc__.split("\n")[0]
    )
    ap.add_argument("--workers", type=int, default=2, help="processes on this machine (default 2)")
    a = ap.parse_args(argv)
    folder = current_results_dir()
    env = json.loads((folder / "envelope.json").read_text(encoding="utf-8"))
    clamped = json.loads((folder / "envelope_bound_clamped.json").read_text(encoding="utf-8"))
    by = {r["index"]: r for r in clamped["conditions"]}
    conds, limits = [], {}
    for r in env["conditions"]:
        c = Condition.from_json(r["condition"])
        peak, lim = peak_and_limit(c)
        if peak < lim:
            conds.append(r["condition"])
            limits[c.index] = {"cooling_peak_A": peak, "limit_A": lim}
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=a.workers) as ex:
        got = list(ex.map(both, conds))
    keep = ("headline_C", "best_pad_headline_C", "clamped_bound_headline_C", "clamped_bound_run")
    rows = [{**g, **limits[g["index"]], **{k: by[g["index"]][k] for k in keep}} for g in got]
    data = {
        **summary(rows, by),
        "clamp_C": list(CLAMP_C),
        "wall_s": time.perf_counter() - t0,
        "workers": a.workers,
        "conditions": rows,
    }
    write_results("envelope_bound_restart", data)
    print(json.dumps({k: v for k, v in data.items() if k != "conditions"}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
