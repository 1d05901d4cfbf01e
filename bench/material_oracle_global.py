"""How optimistic the envelope's local oracle is: the same oracle with each candidate's nuisances fitted
over the whole envelope instead of linearised about the touch's own (issue 23).

``python -m bench.material_oracle_global [--n N] [--workers W]`` writes
``bench/results/material_oracle_global.json``.

The local oracle (telethermo/offline/material_oracle.py, what bench/material_id_envelope.py reports per
stratum) profiles the object's temperature, the contact resistance (force) and the thickness out of every
candidate's trace in its linearisation about the touch's true values. A wrong material that would match the
touch far from those values (a thin copper sheet against a thicker brass one, a light touch on steel against
a firm one on glass) is never tried, so that oracle can only be too kind. Here, for every wrong candidate,
the noiseless touch is first fitted over the envelope (force 0.5–20 N and thickness 0.3–20 mm on a log grid,
the object's temperature profiled through the trace's affine dependence on it, then Gauss–Newton from the
two best grid points on ln F, ln d and T_o, every residual that of a simulated trace); the candidate's trace
and sensitivities are then taken at that best fit (its pseudo-true nuisance), and each noise draw's residual
to it is the smaller of its two linearisations (about the touch's nuisances, as the local oracle, and about
the pseudo-true ones), so this oracle is never kinder than the local one. The true candidate keeps the
touch's own values. Both oracles run on
the same touches, windows and noise draws, so their difference is the local oracle's optimism; the slave's
answers on the same touches (the envelope bench's simulation) give the gap to each, paired.

Touches: the envelope's evaluation draws (material_touches.ENVELOPE), every ``EVERY``-th block of ten
(each material once) outside the near band, the slave's core after ``identify`` on the other module
(bench/material_id_envelope.after_identify).
"""

from __future__ import annotations

import argparse
import math
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np

from bench import material_id_bench as mb
from bench.common import write_results
from bench.material_envelope_oracle import ORACLE_DRAWS, windows
from bench.material_id_envelope import NEAR_C, STRATA, after_identify, run_touch
from telethermo.offline.material_oracle import (
    noise_scale,
    profiled_distances,
    touch_candidates,
    true_traces,
)
from telethermo.offline.material_touches import (
    ENVELOPE,
    ENVELOPE_N,
    SIM_TO_TABLE,
    envelope_draws,
    noise_of,
    other_tem,
)
from telethermo.sim.tem import load_rig_params

#: every EVERY-th envelope touch (outside the near band) is scored
EVERY = 20
FORCE_GRID_N = np.geomspace(0.5, 20.0, 6)
THICK_GRID_M = np.geomspace(0.3e-3, 20e-3, 8)
#: the object's temperature step of the affine profile and its bounds, °C
DT_C, T_BOUNDS_C = 5.0, (0.0, 60.0)
GN_STARTS, GN_ITERS = 2, 3
LN_F_BOUNDS = (math.log(0.5), math.log(20.0))
LN_D_BOUNDS = (math.log(0.3e-3), math.log(20e-3))


class _Touch:
    """One touch's simulator context: whitened traces of any candidate at any nuisance."""

    def __init__(self, params, core, t: dict, window_s: float) -> None:
        self.params, self.core, self.t, self.window_s = params, core, t, window_s
        n_win = int(round(window_s / mb.PERIOD_S))
        self.sigma = noise_scale(noise_of(t["noise_x"]), n_win)

    def trace(self, mat: str, force_N: float, thick_m: float, T_o_C: float) -> np.ndarray:
        t = self.t
        tr = true_traces(
            self.params,
            mat,
            thick_m,
            T_o_C,
            force_N,
            t["T_probe_C"],
            t["t_on_s"],
            mb.PERIOD_S,
            t["ambient_C"],
            self.window_s,
            self.core,
        )
        return tr / self.sigma


def _profile_T(ctx: _Touch, mat: str, f: float, d: float, z: np.ndarray, T_ref: float) -> tuple[float, float]:
    """(squared residual, T_o) of candidate ``mat`` at force ``f``, thickness ``d`` with the object's
    temperature profiled through the trace's affine dependence on it, clipped to the bounds."""
    s0 = ctx.trace(mat, f, d, T_ref)
    g = (ctx.trace(mat, f, d, T_ref + DT_C) - s0) / DT_C
    gg = float(g @ g)
    dT = float(g @ (z - s0)) / gg if gg > 1e-12 else 0.0
    T = float(np.clip(T_ref + dT, *T_BOUNDS_C))
    r = z - s0 - (T - T_ref) * g
    return float(r @ r), T


def _gauss_newton(ctx: _Touch, mat: str, z: np.ndarray, x: np.ndarray) -> tuple[float, np.ndarray]:
    """Refine (ln F, ln d, T_o) from ``x`` by Gauss–Newton with finite differences; every residual is that
    of a simulated trace. Returns (best squared residual, its x)."""

    def sim(v: np.ndarray) -> np.ndarray:
        return ctx.trace(mat, math.exp(v[0]), math.exp(v[1]), v[2])

    lo = np.array([LN_F_BOUNDS[0], LN_D_BOUNDS[0], T_BOUNDS_C[0]])
    hi = np.array([LN_F_BOUNDS[1], LN_D_BOUNDS[1], T_BOUNDS_C[1]])
    s = sim(x)
    best = (float((z - s) @ (z - s)), x)
    h = np.array([0.05, 0.05, 0.5])
    for _ in range(GN_ITERS):
        J = np.column_stack([(sim(x + h * e) - s) / h[i] for i, e in enumerate(np.eye(3))])
        step, *_ = np.linalg.lstsq(J, z - s, rcond=None)
        x = np.clip(x + np.clip(step, -1.0 * np.array([1, 1, 10]), np.array([1, 1, 10])), lo, hi)
        s = sim(x)
        r2 = float((z - s) @ (z - s))
        if r2 < best[0]:
            best = (r2, x)
    return best


def pseudo_true(ctx: _Touch, mat: str, z: np.ndarray) -> tuple[float, float, float]:
    """(force N, thickness m, T_o °C) of candidate ``mat`` that best fits the noiseless touch ``z``."""
    T_ref = ctx.t["T_object_C"]
    grid = [(_profile_T(ctx, mat, f, d, z, T_ref), f, d) for f in FORCE_GRID_N for d in THICK_GRID_M]
    grid.sort(key=lambda g: g[0][0])
    fits = [
        _gauss_newton(ctx, mat, z, np.array([math.log(f), math.log(d), T]))
        for (_, T), f, d in grid[:GN_STARTS]
    ]
    _, x = min(fits, key=lambda r: r[0])
    return math.exp(x[0]), math.exp(x[1]), float(x[2])


def global_candidates(
    ctx: _Touch, sims: list[str]
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, list[dict]]:
    """(z, G) as touch_candidates gives them (the local oracle's), then (z, G) with each wrong candidate's
    trace and sensitivities at its pseudo-true nuisance (:func:`pseudo_true`; the true one's at the touch's
    own), and those nuisances."""
    t = ctx.t
    z_loc, G_loc = touch_candidates(
        ctx.params, sims, t, t["T_probe_C"], mb.PERIOD_S, t["ambient_C"], ctx.sigma, ctx.window_s, ctx.core
    )
    z, G = z_loc.copy(), G_loc.copy()
    fits: list[dict] = []
    for j, mat in enumerate(sims):
        if j == t["class"]:
            continue
        f, d, T = pseudo_true(ctx, mat, z_loc[t["class"]])
        fits.append(
            {"material": mat, "force_N": round(f, 3), "thickness_mm": round(1e3 * d, 3), "T_o_C": round(T, 2)}
        )
        zj, Gj = touch_candidates(
            ctx.params,
            [mat],
            t | {"force_N": f, "thickness_m": d, "T_object_C": T},
            t["T_probe_C"],
            mb.PERIOD_S,
            t["ambient_C"],
            ctx.sigma,
            ctx.window_s,
            ctx.core,
        )
        z[j], G[j] = zj[0], Gj[0]
    return z_loc, G_loc, z, G, fits


def classify(
    z_loc: np.ndarray, G_loc: np.ndarray, z: np.ndarray, G: np.ndarray, truth: int, W: np.ndarray
) -> tuple[list[int], list[int]]:
    """How often each candidate is named over the noise draws ``W`` of candidate ``truth``: by the local
    oracle, and by the global one, which takes for each candidate the better of its two linearisations (at
    the touch's nuisances and at its pseudo-true ones), so that it is never kinder than the local one."""
    obs = z_loc[truth] + W
    d_loc = profiled_distances(z_loc, G_loc, obs)
    d_glob = np.minimum(d_loc, profiled_distances(z, G, obs))
    k = len(z)
    return (
        np.bincount(np.argmin(d_loc, axis=1), minlength=k).tolist(),
        np.bincount(np.argmin(d_glob, axis=1), minlength=k).tolist(),
    )


_WORKER: dict[str, Any] = {}


def _init() -> None:
    base = load_rig_params()
    rigs = {False: base, True: other_tem(base)}
    _WORKER.update(
        rigs=rigs, cores={False: None, True: after_identify(rigs[True])}, sims=list(mb.SIM_TO_TABLE)
    )


def score_touch(t: dict, seed: int) -> dict[str, Any]:
    """The local and the global oracle's accuracy on touch ``t`` over each answer's window, the same noise
    draws for both; the global fit of every wrong candidate."""
    if not _WORKER:
        _init()
    rigs, cores, sims = _WORKER["rigs"], _WORKER["cores"], _WORKER["sims"]
    rng = np.random.default_rng(seed)
    out: dict[str, Any] = {
        k: t[k]
        for k in (
            "class",
            "T_object_C",
            "T_probe_C",
            "force_N",
            "thickness_m",
            "ambient_C",
            "noise_x",
            "other_tem",
        )
    }
    for stage, w in windows().items():
        ctx = _Touch(rigs[t["other_tem"]], cores[t["other_tem"]], t, w)
        z_loc, G_loc, z, G, fits = global_candidates(ctx, sims)
        W = rng.standard_normal((ORACLE_DRAWS, z.shape[1]))
        local, glob = classify(z_loc, G_loc, z, G, t["class"], W)
        out[stage] = {
            "local": local,
            "global": glob,
            "pseudo_true": fits,
        }
    return out


def touches(n: int) -> list[dict]:
    """Every EVERY-th block of ten of the envelope's first ``n`` evaluation touches (each material once a
    block), outside the near band, with the probe's resting temperature."""
    base = load_rig_params()
    rigs = {False: base, True: other_tem(base)}
    out = []
    for i, t in enumerate(envelope_draws(n, ENVELOPE)):
        if (i // len(SIM_TO_TABLE)) % EVERY:
            continue
        t = t | {"T_probe_C": mb.finger_natural_C(rigs[t["other_tem"]], t["ambient_C"])}
        if abs(t["T_object_C"] - t["T_probe_C"]) >= NEAR_C:
            out.append(t)
    return out


def answers(ts: list[dict]) -> list[dict]:
    """What the slave published on each touch (bench/material_id_envelope.run_touch: the same simulation as
    the envelope bench's), refined and early."""
    if not _WORKER:
        _init()
    names = [mb.SIM_TO_TABLE[m] for m in _WORKER["sims"]]
    rows = [run_touch(_WORKER["rigs"], t, _WORKER["sims"], names, _WORKER["cores"]) for t in ts]
    return [{"late": r["answer"], "early": r["answer_early"]} for r in rows]


def summarise(rows: list[dict]) -> dict[str, Any]:
    """Per answer's window, over all touches and per stratum: the local and global oracle's accuracy, the
    slave's answer's (abstains wrong) on the same touches, and the paired gap to the global oracle with its
    standard error."""
    out: dict[str, Any] = {}
    for stage in windows():

        def one(rs: list[dict]) -> dict[str, Any]:
            if not rs:
                return {"n": 0}
            loc = np.array([r[stage]["local"][r["class"]] / ORACLE_DRAWS for r in rs])
            glo = np.array([r[stage]["global"][r["class"]] / ORACLE_DRAWS for r in rs])
            ans = np.array([float(r["answer"][stage] == r["class"]) for r in rs])
            return {
                "n": len(rs),
                "local": round(float(loc.mean()), 3),
                "global": round(float(glo.mean()), 3),
                "answer": round(float(ans.mean()), 3),
            } | paired_gap(glo, ans, "gap_to_global")

        out[stage] = by_stratum(rows, one)
    return out


def paired_gap(ref: np.ndarray, ans: np.ndarray, key: str) -> dict[str, Any]:
    """The mean of ``ref − ans`` (per touch: 1 right, 0 wrong, or an oracle's share of draws) as ``key`` and
    its standard error as ``gap_se`` (None for one touch)."""
    gap = np.asarray(ref, float) - np.asarray(ans, float)
    se = round(float(gap.std(ddof=1) / math.sqrt(gap.size)), 3) if gap.size > 1 else None
    return {key: round(float(gap.mean()), 3), "gap_se": se}


def by_stratum(rows: list[dict], one: Any) -> dict[str, Any]:
    """``one`` of all ``rows`` (``all_outside_near_band``) and of each envelope stratum's
    (bench/material_id_envelope.STRATA)."""
    per = {"all_outside_near_band": rows} | {k: [r for r in rows if f(r)] for k, f in STRATA.items()}
    return {k: one(rs) for k, rs in per.items()}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--n", type=int, default=ENVELOPE_N, help="envelope touches drawn (every 20th block of ten scored)"
    )
    ap.add_argument("--workers", type=int, default=2)
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    ts = touches(a.n)
    with ProcessPoolExecutor(a.workers) as ex:
        rows = list(ex.map(score_touch, ts, [9000 + i for i in range(len(ts))]))
    rows = [r | {"answer": ans} for r, ans in zip(rows, answers(ts))]
    summary = summarise(rows)
    res = {
        "material_oracle_global_n_touches": len(rows),
        "material_oracle_answer_late": summary["late"]["all_outside_near_band"]["answer"],
        "material_oracle_answer_early": summary["early"]["all_outside_near_band"]["answer"],
        "material_oracle_local_late": summary["late"]["all_outside_near_band"]["local"],
        "material_oracle_global_late": summary["late"]["all_outside_near_band"]["global"],
        "material_oracle_local_early": summary["early"]["all_outside_near_band"]["local"],
        "material_oracle_global_early": summary["early"]["all_outside_near_band"]["global"],
        "strata": summary,
        "windows_s": windows(),
        "touches": rows,
        "method": __doc__,
        "run_s": round(time.perf_counter() - t0, 1),
    }
    write_results("material_oracle_global", res)
    for stage, st in summary.items():
        for k, v in st.items():
            print(
                f"{stage:5} {k:36} n {v['n']:4}  answer {v.get('answer')}  local {v.get('local')}  "
                f"global {v.get('global')}  gap {v.get('gap_to_global')} (SE {v.get('gap_se')})"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
