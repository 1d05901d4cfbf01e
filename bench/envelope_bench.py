"""The operating envelope benchmark (issue 22): ``python -m bench.envelope_bench [--quick] [--workers N]
[--dask ADDRESS]`` writes ``bench/results/envelope.json`` and ``envelope.png``.

Conditions: :func:`telethermo.offline.envelope.draw_conditions` (a seeded Latin hypercube of N_LHS points over
the envelope plus the 16 corners of object temperature × room × both TEMs' Seebeck × delay), each a full
§5.3 session scored against its own direct touch and the best constant pad (telethermo.offline.envelope).
Sessions are submitted to a ``concurrent.futures`` executor: processes on this machine by default, or a Dask
distributed cluster (``--dask tcp://host:8786``; ``dask[distributed]`` is the optional ``cluster`` extra)
through
its ``Client.get_executor()``. The same run measures the wall time of the first WORKERS_PROBE conditions on
one
worker and on two (``workers_2_speedup``).

Reported per figure: the median, the 10 % worst and the worst condition; every failing condition with its
parameters. Not computed here (named in the results): the optimal-current bound on a subset
(telethermo/offline/bound.py takes minutes per condition), so ``envelope_median_ratio_to_bound`` and
``envelope_captured_fraction_median`` are null.
"""

from __future__ import annotations

import argparse
import json
import dataclasses
import time
from concurrent.futures import Executor, ProcessPoolExecutor
from typing import Any, Iterable

import numpy as np

from bench.common import current_results_dir, write_results
from bench.bound_run import run_bound
from bench.transparency_bench import reference_track
from telethermo.offline import render_sweep
from telethermo.offline.finger_betas import simulated_user_table
from telethermo.offline.envelope import (
    CLAMP_REACH_C,
    Condition,
    base_condition,
    condition_scene,
    draw_conditions,
    run_condition,
)

SEED = 22_2026  # the design's seed: nothing is fitted on these draws (the gains are the shipped ones)
N_LHS, N_LHS_QUICK = 200, 3
WORKERS_PROBE = 6
FIGURES = ("headline_C", "pre_contact_C", "early_C", "late_C", "oscillation_ratio", "best_pad_headline_C")


BOUND_EVERY = 10  # the bound subset: every 10th Latin-hypercube condition (20 of 200) and the base scene


def safe_score(c: Condition, with_shipped: bool = True) -> dict[str, Any]:
    """One condition: identified gains (scored), the shipped gains on the same draw (the before-figure; not
    with ``with_shipped=False``) and the pads; or a row that says why it could not be scored (failing)."""
    try:
        return run_condition(c, gains="identified", with_shipped=with_shipped)
    except Exception as exc:  # one broken condition must not lose the matrix; it is listed, never hidden
        return {"condition": dataclasses.asdict(c), "error": f"{type(exc).__name__}: {exc}"}


def bound_of(
    c: Condition, clamp_C: tuple[float, float] | None = None, restarts_A: tuple[float, ...] = ()
) -> dict[str, Any]:
    """The optimal-current bound of condition ``c`` (telethermo.offline.bound: exact master plant, finger
    matched before each touch, no foreknowledge), mean of the touches' window errors, °C. With ``clamp_C``
    (lo, hi), °C, the clamped bound, and the skin's largest excursion beyond the clamps
    (``clamp_excess_max_C``). ``restarts_A``: further starting currents of the search (A)."""
    sc, _ = condition_scene(c)
    t_ref, skin_ref, _q, cells = reference_track(sc)
    b = run_bound(
        sc,
        t_ref,
        skin_ref,
        cells,
        maxiter=150,
        front_weights=(),
        front_touches=0,
        clamp_C=clamp_C,
        restarts_A=restarts_A,
    )
    out = {
        "index": c.index,
        "bound_headline_C": float(np.mean([p["window_C"] for p in b["per_touch"]])),
        "replay_max_diff_C": float(max(p["replay_max_diff_C"] for p in b["per_touch"])),
    }
    if clamp_C is not None:
        out["clamp_excess_max_C"] = float(max(p["clamp_excess_C"] for p in b["per_touch"]))
    return out


def run_all(executor: Executor, conds: Iterable[Condition]) -> list[dict[str, Any]]:
    """Score every condition on ``executor`` (results in the conditions' order)."""
    return list(executor.map(safe_score, conds))


def timed(workers: int, conds: list[Condition]) -> float:
    """Wall time of the shipped-gains sessions of ``conds`` on ``workers`` processes, s."""
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=workers) as ex:
        list(ex.map(_shipped_only, conds))
    return time.perf_counter() - t0


def _shipped_only(c: Condition) -> dict[str, Any]:
    return run_condition(c, with_pads=False, gains="shipped")


def spread(rows: list[dict[str, Any]], key: str) -> dict[str, Any]:
    """Median, 10 % worst (90th percentile: larger is worse) and the worst condition of one figure."""
    v = np.array([r[key] for r in rows], dtype=float)
    ok = np.isfinite(v)
    if not ok.any():
        return {"median": None, "worst10": None, "worst": None, "worst_condition": None}
    k = int(np.nanargmax(np.where(ok, v, -np.inf)))
    return {
        "median": float(np.median(v[ok])),
        "worst10": float(np.percentile(v[ok], 90)),
        "worst": float(v[k]),
        "worst_condition": rows[k]["condition"],
    }


def failures(r: dict[str, Any]) -> list[str]:
    why = []
    if r["oscillating"]:
        why.append(f"oscillation ratio {r['oscillation_ratio']:.2f}")
    if r["session_long_cut"]:
        why.append(f"session-long cut {r['time_cut_s']}")
    if r["trips"]:
        why.append("trips " + ", ".join(f"{x['side']}:{x['trip']}" for x in r["trips"]))
    if not r.get("beats_best_pad", True):
        why.append(
            f"headline {r['headline_C']:.3f} >= best pad {r['best_pad_headline_C']:.3f} ({r['best_pad']})"
        )
    if r["cue_fair"] and not r["cue_order_kept"]:
        why.append("cue order lost")
    if (r.get("clamp_short_C") or 0.0) > CLAMP_REACH_C:
        why.append(
            f"skin {r['clamp_short_C']:.2f} °C short of the clamp the direct touch passes"
            f" (a pad held at it: {r['clamp_short_pad_C']:.2f})"
        )
    if r.get("skin_past_clamp_C", 0.0) > 0.0:
        why.append(f"skin {r['skin_min_C']:.2f}..{r['skin_max_C']:.2f} °C, past its clamp")
    return why


def bound_summary(
    rows: list[dict[str, Any]], bounds: list[dict[str, Any]], base: dict[str, Any]
) -> dict[str, Any]:
    """Ratio to the bound and the captured share of the improvement the physics allows over the best pad."""
    by = {r["condition"]["index"]: r for r in rows}
    by[base["condition"]["index"]] = base
    per = []
    for b in bounds:
        r = by.get(b["index"])
        if r is None:  # a condition that could not be scored (listed in envelope_conditions_not_scored)
            continue
        pad, proj, bnd = r["best_pad_headline_C"], r["headline_C"], b["bound_headline_C"]
        per.append(
            {
                "index": b["index"],
                "headline_C": proj,
                "bound_headline_C": bnd,
                "best_pad_headline_C": pad,
                "ratio_to_bound": proj / bnd,
                "captured_fraction": (pad - proj) / (pad - bnd) if pad > bnd else None,
                "replay_max_diff_C": b["replay_max_diff_C"],
                "condition": r["condition"],
            }
        )
    ratios = [p["ratio_to_bound"] for p in per]
    cap = [p["captured_fraction"] for p in per if p["captured_fraction"] is not None]
    return {
        "envelope_median_ratio_to_bound": float(np.median(ratios)) if ratios else None,
        "envelope_worst_ratio_to_bound": float(np.max(ratios)) if ratios else None,
        "envelope_captured_fraction_median": float(np.median(cap)) if cap else None,
        "envelope_captured_fraction_worst": float(np.min(cap)) if cap else None,
        "bound_subset": f"every {BOUND_EVERY}th Latin-hypercube condition "
        f"(indices 0, {BOUND_EVERY}, ...) and the "
        "base scene: chosen by index before any result, so neither easy nor hard by selection",
        "bound_conditions": per,
    }


def skin_summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The operator's skin past its clamps: the worst condition's excursion, °C, and the conditions past."""
    past = [r.get("skin_past_clamp_C", float("nan")) for r in rows]
    known = [p for p in past if np.isfinite(p)]
    return {
        "envelope_skin_past_clamp_worst_C": max(known) if known else None,
        "envelope_skin_past_clamp_conditions": [
            r["condition"]["index"] for r, p in zip(rows, past) if np.isfinite(p) and p > 0.0
        ],
    }


def clamp_summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Where the direct touch's skin passes a clamp: the share of conditions whose display skin comes within
    CLAMP_REACH_C of it (issue 22, item 4), how far short it stays, and the same for a pad held at that clamp
    in the same run (as near as a pad that may not pass the clamp brings the skin)."""
    crossed = [r for r in rows if r.get("clamp_short_C") is not None]
    if not crossed:
        return {"envelope_clamp_crossed_conditions": 0, "envelope_clamp_reached_fraction": None}
    short = np.array([r["clamp_short_C"] for r in crossed])
    pad = np.array([r["clamp_short_pad_C"] for r in crossed])
    return {
        "envelope_clamp_crossed_conditions": len(crossed),
        "envelope_clamp_reached_fraction": float(np.mean(short <= CLAMP_REACH_C)),
        "envelope_clamp_reached_fraction_pad": float(np.mean(pad <= CLAMP_REACH_C)),
        "envelope_clamp_short_median_C": float(np.median(short)),
        "envelope_clamp_short_worst_C": float(short.max()),
        "envelope_clamp_short_pad_median_C": float(np.median(pad)),
        "envelope_clamp_short_pad_worst_C": float(pad.max()),
        "envelope_clamp_short_beyond_pad_worst_C": float((short - pad).max()),
        "envelope_clamp_short_conditions": [
            {
                "index": r["condition"]["index"],
                "short_C": r["clamp_short_C"],
                "pad_short_C": r["clamp_short_pad_C"],
                "finger_force_N": r["condition"]["finger_force_N"],
                "object_T_C": r["condition"]["object_T_C"],
            }
            for r in crossed
            if r["clamp_short_C"] > CLAMP_REACH_C
        ],
    }


def shipped_summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The shipped gains on the same draws (the before-figure)."""
    return {
        "oscillating_conditions": sum(r["shipped"]["oscillating"] for r in rows),
        "headline_median_C": float(np.median([r["shipped"]["headline_C"] for r in rows])),
        "headline_worst_C": float(np.max([r["shipped"]["headline_C"] for r in rows])),
        "session_long_cuts": sum(r["shipped"]["session_long_cut"] for r in rows),
        "conditions_with_trips": sum(r["shipped"]["trips"] > 0 for r in rows),
    }


def summarise(all_rows: list[dict[str, Any]], base: dict[str, Any]) -> dict[str, Any]:
    rows = [r for r in all_rows if "error" not in r]
    errors = [r for r in all_rows if "error" in r]
    fair = [r for r in rows if r["cue_fair"]]
    fails = [
        {
            "condition": r["condition"],
            "why": failures(r),
            "headline_C": r["headline_C"],
            "best_pad_headline_C": r.get("best_pad_headline_C"),
        }
        for r in rows
        if failures(r)
    ]
    return {
        "envelope_n_conditions": len(rows),
        "envelope_conditions_not_scored": [
            {"condition": r["condition"], "error": r["error"]} for r in errors
        ],
        "envelope_identify_refused": sum(
            any(f.get("identify_refused") for f in r.get("gain_fit", {}).values()) for r in rows
        ),
        "envelope_oscillating_conditions": sum(r["oscillating"] for r in rows),
        "envelope_session_long_cuts": sum(r["session_long_cut"] for r in rows),
        "envelope_unexpected_trips": sum(bool(r["trips"]) for r in rows),
        "envelope_beats_best_pad_fraction": float(np.mean([r["beats_best_pad"] for r in rows])),
        "envelope_cue_order_kept_fraction": float(np.mean([r["cue_order_kept"] for r in fair]))
        if fair
        else None,
        "envelope_cue_fair_conditions": len(fair),
        **skin_summary(rows),
        **clamp_summary(rows),
        **({"shipped_gains": shipped_summary(rows)} if all("shipped" in r for r in rows) else {}),
        "base_headline_C": base["headline_C"],
        "base_pre_contact_C": base["pre_contact_C"],
        "base_oscillation_ratio": base["oscillation_ratio"],
        "base_best_pad_headline_C": base["best_pad_headline_C"],
        "figures": {k: spread(rows, k) for k in FIGURES},
        "ratio_to_best_pad": spread(
            [{**r, "ratio": r["headline_C"] / r["best_pad_headline_C"]} for r in rows], "ratio"
        ),
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
    ax[0].set(
        xlabel="best constant pad headline °C",
        ylabel="controller headline °C",
        title="below the line: the controller beats the pad (colour: object °C)",
    )
    ax[1].scatter(sb, osc, s=14)
    ax[1].axhline(1.5, color="r", lw=0.8)
    ax[1].set(
        yscale="log",
        xlabel="master TEM Seebeck ×",
        ylabel="oscillation ratio",
        title="oscillation (limit 1.5)",
    )
    ax[2].scatter(To, h, s=14, label="controller")
    ax[2].scatter(To, p, s=10, marker="x", label="best pad")
    ax[2].set(xlabel="object initial °C", ylabel="headline °C", title="headline across object temperature")
    ax[2].legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.envelope_bench", description=__doc__.split("\n")[0])
    ap.add_argument(
        "--quick", action="store_true", help=f"{N_LHS_QUICK} conditions, no corners, no speed-up probe"
    )
    ap.add_argument("--workers", type=int, default=2, help="processes on this machine (default 2)")
    ap.add_argument("--dask", metavar="ADDRESS", help="submit to a Dask distributed scheduler instead")
    ap.add_argument(
        "--render-only",
        action="store_true",
        help="re-measure only the render sweep and replace its keys in an existing envelope.json",
    )
    a = ap.parse_args(argv)
    if a.render_only:
        render_only(a.workers)
        return 0
    run(quick=a.quick, workers=a.workers, dask=a.dask)
    return 0


def render_only(workers: int) -> dict[str, Any]:
    """The render sweep alone, its keys replaced in the existing envelope.json (the rest kept as measured)."""
    path = current_results_dir() / "envelope.json"
    old = json.loads(path.read_text(encoding="utf-8"))
    grid = [(m, T) for m in render_sweep.MATERIALS for T in render_sweep.OBJECT_T_C]
    table = simulated_user_table()
    with ProcessPoolExecutor(max_workers=workers) as ex:
        futs = [ex.submit(render_sweep.render_touch_both, m, T, table) for m, T in grid]
        render = [f.result() for f in futs]
    # the matrix's keys keep the commit they were measured on
    old["matrix_provenance"] = old.pop("matrix_provenance", None) or old.pop("provenance", None)
    old.pop("provenance", None)
    old.pop("render_provenance", None)  # the render sweep is this commit's (``provenance``)
    out = {**old, **render_sweep.summarise(render), "render_table": table, "render_touches": render}
    write_results("envelope", out)
    print(
        f"render_early_rms_worst_C {out['render_early_rms_worst_C']:.4g}; "
        "beyond the band, skin to clamp worst "
        f"{out['render_beyond_band_skin_to_clamp_worst_C']:.4g} °C"
    )
    return out


def run(*, quick: bool = False, workers: int = 2, dask: str | None = None) -> dict[str, Any]:
    """Run the matrix and write envelope.json and envelope.png into the results folder."""
    a = argparse.Namespace(quick=quick, workers=workers, dask=dask)
    t0 = time.perf_counter()
    conds = draw_conditions(N_LHS_QUICK if a.quick else N_LHS, SEED, corners=not a.quick)
    speed: dict[str, Any] = {}
    if not a.quick:
        probe = conds[:WORKERS_PROBE]
        t1, t2 = timed(1, probe), timed(2, probe)
        speed = {
            "workers_1_s": t1,
            "workers_2_s": t2,
            "workers_2_speedup": t1 / t2,
            "probe_conditions": len(probe),
        }
    bound_set = (
        []
        if a.quick
        else [base_condition()] + [c for c in conds if c.design == "lhs" and c.index % BOUND_EVERY == 0]
    )

    grid = [(m, T) for m in render_sweep.MATERIALS for T in render_sweep.OBJECT_T_C]
    table = simulated_user_table()  # the simulated operator's own β (as a lab's calibrate-render-table)
    if a.quick:
        grid = [("aluminium", 10.0), ("oak", 25.0), ("copper", 45.0)]

    def matrix(ex: Executor) -> tuple[list[dict[str, Any]], dict[str, Any], list[dict[str, Any]], list[Any]]:
        fut_base = ex.submit(run_condition, base_condition(), gains="identified", with_shipped=True)
        fut_bounds = [ex.submit(bound_of, c) for c in bound_set]
        fut_render = [ex.submit(render_sweep.render_touch_both, m, T, table) for m, T in grid]
        rows = run_all(ex, conds)
        return rows, fut_base.result(), [f.result() for f in fut_bounds], [f.result() for f in fut_render]

    if a.dask:
        from dask.distributed import Client  # optional extra: pip install '.[cluster]'

        with Client(a.dask) as client:
            rows, base, bounds, render = matrix(client.get_executor())
    else:
        with ProcessPoolExecutor(max_workers=a.workers) as ex:
            rows, base, bounds, render = matrix(ex)
    ok = [r for r in rows if "error" not in r]
    out = {
        "quick": a.quick,
        "seed": SEED,
        **summarise(rows, base),
        **bound_summary(ok, bounds, base),
        **speed,
        **render_sweep.summarise(render),
        "render_table": table,
        "render_touches": render,
        "matrix_wall_s": time.perf_counter() - t0,
        "workers": a.workers,
        "base": base,
        "conditions": rows,
    }
    out["workers_2_speedup"] = speed.get("workers_2_speedup")
    write_results("envelope", out)
    plot(ok, str(current_results_dir() / "envelope.png"))
    keys = [
        k
        for k in out
        if k.startswith(
            ("envelope_", "base_", "workers_", "render_early_rms_worst_C", "render_beyond_band_skin")
        )
    ]
    for k in keys:
        v = out[k]
        print(f"{k:40s} {v if not isinstance(v, float) else f'{v:.4g}'}")
    print(
        f"failing conditions: {len(out['failing_conditions'])} of {len(rows)} "
        f"(not scored: {len(out['envelope_conditions_not_scored'])}); wall {out['matrix_wall_s']:.0f} s"
    )
    return out


if __name__ == "__main__":
    raise SystemExit(main())
