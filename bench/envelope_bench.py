"""The operating envelope benchmark (issue 22): ``python -m bench.envelope_bench [--quick] [--workers N]
[--dask ADDRESS]`` writes ``bench/results/envelope.json`` and ``envelope.png``.

Conditions: :func:`telethermo.offline.envelope.draw_conditions` (a seeded Latin hypercube of N_LHS points over
the envelope plus the 16 corners of object temperature × room × both TEMs' Seebeck × delay), each a full
§5.3 session scored against its own direct touch and the best constant pad (telethermo.offline.envelope).
Sessions are submitted to a ``concurrent.futures`` executor: processes on this machine by default, or a Dask
distributed cluster (``--dask tcp://host:8786``; ``dask[distributed]`` is the optional ``cluster`` extra) through
its ``Client.get_executor()``. The same run measures the wall time of the first WORKERS_PROBE conditions on one
worker and on two (``workers_2_speedup``).

Reported per figure: the median, the 10 % worst and the worst condition; every failing condition with its
parameters. Not computed here (named in the results): the optimal-current bound on a subset (bench/bound.py
takes minutes per condition), so ``envelope_median_ratio_to_bound`` and ``envelope_captured_fraction_median``
are null.
"""
from __future__ import annotations

import argparse
import math
import time
from concurrent.futures import Executor, ProcessPoolExecutor
from typing import Any, Iterable

import numpy as np

from bench.common import current_results_dir, write_results
from telethermo.offline.envelope import Condition, base_condition, draw_conditions, run_condition

SEED = 22_2026          # the design's seed: nothing is fitted on these draws (the gains are the shipped ones)
N_LHS, N_LHS_QUICK = 200, 4
WORKERS_PROBE = 8
FIGURES = ("headline_C", "pre_contact_C", "early_C", "late_C", "oscillation_ratio", "best_pad_headline_C")


def run_all(executor: Executor, conds: Iterable[Condition]) -> list[dict[str, Any]]:
    """Score every condition on ``executor`` (results in the conditions' order)."""
    return list(executor.map(run_condition, conds))


def timed(workers: int, conds: list[Condition]) -> float:
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=workers) as ex:
        run_all(ex, conds)
    return time.perf_counter() - t0


def spread(rows: list[dict[str, Any]], key: str) -> dict[str, Any]:
    """Median, 10 % worst (90th percentile: larger is worse) and the worst condition of one figure."""
    v = np.array([r[key] for r in rows], dtype=float)
    ok = np.isfinite(v)
    if not ok.any():
        return {"median": None, "worst10": None, "worst": None, "worst_condition": None}
    k = int(np.nanargmax(np.where(ok, v, -np.inf)))
    return {"median": float(np.median(v[ok])), "worst10": float(np.percentile(v[ok], 90)),
            "worst": float(v[k]), "worst_condition": rows[k]["condition"]}


def failures(r: dict[str, Any]) -> list[str]:
    why = []
    if r["oscillating"]:
        why.append(f"oscillation ratio {r['oscillation_ratio']:.2f}")
    if r["session_long_cut"]:
        why.append(f"session-long cut {r['time_cut_s']}")
    if r["trips"]:
        why.append("trips " + ", ".join(f"{x['side']}:{x['trip']}" for x in r["trips"]))
    if not r.get("beats_best_pad", True):
        why.append(f"headline {r['headline_C']:.3f} >= best pad {r['best_pad_headline_C']:.3f} ({r['best_pad']})")
    if r["cue_fair"] and not r["cue_order_kept"]:
        why.append("cue order lost")
    return why


def summarise(rows: list[dict[str, Any]], base: dict[str, Any]) -> dict[str, Any]:
    fair = [r for r in rows if r["cue_fair"]]
    fails = [{"condition": r["condition"], "why": failures(r), "headline_C": r["headline_C"],
              "best_pad_headline_C": r.get("best_pad_headline_C")} for r in rows if failures(r)]
    return {
        "envelope_n_conditions": len(rows),
        "envelope_oscillating_conditions": sum(r["oscillating"] for r in rows),
        "envelope_session_long_cuts": sum(r["session_long_cut"] for r in rows),
        "envelope_unexpected_trips": sum(bool(r["trips"]) for r in rows),
        "envelope_beats_best_pad_fraction": float(np.mean([r["beats_best_pad"] for r in rows])),
        "envelope_cue_order_kept_fraction": float(np.mean([r["cue_order_kept"] for r in fair])) if fair else None,
        "envelope_cue_fair_conditions": len(fair),
        "envelope_median_ratio_to_bound": None, "envelope_captured_fraction_median": None,
        "bound_note": "not computed in this run (bench/bound.py costs minutes per condition)",
        "base_headline_C": base["headline_C"], "base_pre_contact_C": base["pre_contact_C"],
        "base_oscillation_ratio": base["oscillation_ratio"], "base_best_pad_headline_C": base["best_pad_headline_C"],
        "figures": {k: spread(rows, k) for k in FIGURES},
        "ratio_to_best_pad": spread([{**r, "ratio": r["headline_C"] / r["best_pad_headline_C"]} for r in rows],
                                    "ratio"),
        "failing_conditions": fails,
    }


def plot(rows: list[dict[str, Any]], path: str) -> None:
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.5))
    h = np.array([r["headline_C"] for r in rows])
    p = np.array([r["best_pad_headline_C"] for r in rows])
    osc = np.array([r["oscillation_ratio"] for r in rows])
    To = np.array([r["condition"]["object_T_C"] for r in rows])
    sb = np.array([r["condition"]["m_seebeck_x"] for r in rows])
    ax[0].scatter(p, h, c=To, cmap="coolwarm", s=14)
    lim = [0, max(np.nanmax(h), np.nanmax(p)) * 1.05]
    ax[0].plot(lim, lim, "k--", lw=0.8)
    ax[0].set(xlabel="best constant pad headline °C", ylabel="controller headline °C",
              title="below the line: the controller beats the pad (colour: object °C)")
    ax[1].scatter(sb, osc, s=14)
    ax[1].axhline(1.5, color="r", lw=0.8)
    ax[1].set(yscale="log", xlabel="master TEM Seebeck ×", ylabel="oscillation ratio", title="oscillation (limit 1.5)")
    ax[2].scatter(To, h, s=14, label="controller")
    ax[2].scatter(To, p, s=10, marker="x", label="best pad")
    ax[2].set(xlabel="object initial °C", ylabel="headline °C", title="headline across object temperature")
    ax[2].legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.envelope_bench", description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help=f"{N_LHS_QUICK} conditions, no corners, no speed-up probe")
    ap.add_argument("--workers", type=int, default=2, help="processes on this machine (default 2)")
    ap.add_argument("--dask", metavar="ADDRESS", help="submit to a Dask distributed scheduler instead")
    a = ap.parse_args(argv)
    run(quick=a.quick, workers=a.workers, dask=a.dask)
    return 0


def run(*, quick: bool = False, workers: int = 2, dask: str | None = None) -> dict[str, Any]:
    """Run the matrix and write envelope.json and envelope.png into the results folder."""
    a = argparse.Namespace(quick=quick, workers=workers, dask=dask)
    t0 = time.perf_counter()
    conds = draw_conditions(N_LHS_QUICK if a.quick else N_LHS, SEED, corners=not a.quick)
    speed: dict[str, Any] = {}
    if not a.quick:
        probe = conds[:WORKERS_PROBE]
        t1, t2 = timed(1, probe), timed(2, probe)
        speed = {"workers_1_s": t1, "workers_2_s": t2, "workers_2_speedup": t1 / t2, "probe_conditions": len(probe)}
    if a.dask:
        from dask.distributed import Client          # optional extra: pip install '.[cluster]'
        with Client(a.dask) as client:
            rows = run_all(client.get_executor(), conds)
            base = run_condition(base_condition())
    else:
        with ProcessPoolExecutor(max_workers=a.workers) as ex:
            fut_base = ex.submit(run_condition, base_condition())
            rows = run_all(ex, conds)
            base = fut_base.result()
    out = {"quick": a.quick, "seed": SEED, **summarise(rows, base), **speed,
           "matrix_wall_s": time.perf_counter() - t0, "workers": a.workers, "conditions": rows}
    out["workers_2_speedup"] = speed.get("workers_2_speedup")
    write_results("envelope", out)
    plot(rows, str(current_results_dir() / "envelope.png"))
    keys = [k for k in out if k.startswith("envelope_") or k.startswith("base_") or k.startswith("workers_")]
    for k in keys:
        v = out[k]
        print(f"{k:40s} {v if not isinstance(v, float) else f'{v:.4g}'}")
    print(f"failing conditions: {len(out['failing_conditions'])} of {len(rows)}; wall {out['matrix_wall_s']:.0f} s")
    return out


if __name__ == "__main__":
    raise SystemExit(main())
