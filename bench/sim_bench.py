"""Benchmark of the simulator (sim/): wall time per simulated second against error, the solve_ivp baseline,
and what scene pruning buys.

Scene: the first 10 s of ``probe_touches_al_steel_wood`` (two rigs; the slave touches aluminium then steel,
the operator's finger is on the master all along), both rigs driven open loop by the same seeded
piecewise-constant current sequence (new level every 0.25 s, uniform in ±1.5 A), lockstep at the scene's
10 ms period: apply_current, advance, read - exactly what a node does each SYNC.

Error = max |ΔT| over the run, both rigs, of the true sensor mid-plane, pad-plate and contact-surface
temperatures, against a refined reference (8× finer first cell, growth 1.1, 8 cells per diffusion length,
1 ms steps with the same held currents).

Baseline "what a user would write": scipy.integrate.solve_ivp(method="BDF") on the SAME method-of-lines
system (same grid, same matrices, analytic Jacobian), called once per control period (the controller is in
the loop), restarted at each contact change. Tolerances are swept; "equal error" compares with the
loosest tolerance whose error is within 10 % (or below) of the default simulator's error.

Run: ``python -m bench.sim_bench [--quick]``; writes bench/results/sim.json.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import time

import numpy as np
from scipy.integrate import solve_ivp

from telethermo import sim
from bench.common import median_time_s, print_table, write_results
from telethermo.sim.plant import GRID_PRESETS, GridSettings
from telethermo.sim.tem import KELVIN

SCENE = "probe_touches_al_steel_wood"
DURATION_S = 10.0
REFINED = GridSettings(t_min_s=0.01 / 8, ratio=1.1, cells_per_length=8.0)
# the simulator's grid presets (sim.plant.GRID_PRESETS) at the scene's 10 ms period; the errors recorded in
# GRID_PRESETS (used to pick a grid from a scene's tolerance) are the ones this benchmark measures
GRIDS = {
    name: GridSettings(t_min_s=0.01 * t_fac, ratio=ratio, cells_per_length=cpl)
    for name, (t_fac, ratio, cpl, _err) in GRID_PRESETS.items()
}


def scene_10s():
    return dataclasses.replace(sim.load_scene(SCENE), duration_s=DURATION_S)


def currents(n: int, period_s: float, seed: int = 42) -> np.ndarray:
    hold = max(1, int(round(0.25 / period_s)))
    rng = np.random.default_rng(seed)
    return np.repeat(rng.uniform(-1.5, 1.5, n // hold + 1), hold)[:n]


def run_sim(
    scene,
    *,
    grid: GridSettings | None = None,
    substeps: int = 1,
    prune: bool = True,
    duration_s: float = DURATION_S,
    record: bool = True,
):
    """Two rigs in lockstep; returns the (n, 6) array of true temperatures (or None)."""
    rigs = [sim.build_rig(scene, r, grid=grid, prune=prune) for r in ("master", "slave")]
    n = int(round(duration_s / scene.period_s))
    I = currents(n, scene.period_s)
    dt = scene.period_s / substeps
    out = np.empty((n, 6)) if record else None
    for k in range(n):
        for j, rig in enumerate(rigs):
            rig.apply_current(I[k] if j == 0 else -I[k])
            for _ in range(substeps):
                rig.advance(dt)
            rig.read()
            if record:
                t = rig.truth()
                out[k, 3 * j : 3 * j + 3] = (t.T_sensor_true_C, t.T_pad_C, t.T_surface_C)
    return out


def paired_ratio(slow, fast, repeats: int) -> tuple[float, float, float]:
    """Median over interleaved pairs of time(slow)/time(fast), and the median times (s): interleaving makes
    the ratio robust to the load of a shared machine drifting during the run."""
    ratios, ts, tf = [], [], []
    slow(), fast()  # warm-up
    for _ in range(repeats):
        t0 = time.perf_counter()
        slow()
        t1 = time.perf_counter()
        fast()
        t2 = time.perf_counter()
        ts.append(t1 - t0)
        tf.append(t2 - t1)
        ratios.append((t1 - t0) / (t2 - t1))
    return statistics.median(ratios), statistics.median(ts), statistics.median(tf)


def max_err(a: np.ndarray, b: np.ndarray) -> float:
    d = np.abs(a - b)
    return float(np.nanmax(d))


# ---- the solve_ivp baseline on the same method-of-lines system ---------------------------------------
def run_bdf(scene, rtol: float, atol: float, duration_s: float):
    """Same plant (default grid), integrated by solve_ivp BDF once per period; returns the truth array."""
    rigs = [sim.build_rig(scene, r, noise=False) for r in ("master", "slave")]
    n = int(round(duration_s / scene.period_s))
    I = currents(n, scene.period_s)
    dt = scene.period_s
    out = np.empty((n, 6))
    for k in range(n):
        for j, rig in enumerate(rigs):
            cur = I[k] if j == 0 else -I[k]
            rig.apply_current(cur)
            t_end = rig.t_s + dt
            while rig.t_s < t_end - 1e-9:  # honour contact events like the simulator does
                t_stop = min(t_end, rig._next_event) if rig._next_event > rig.t_s + 1e-9 else t_end
                _bdf_segment(rig, cur, t_stop - rig.t_s, rtol, atol)
                rig.t_s = t_stop
                if abs(rig.t_s - rig._next_event) <= 1e-9:
                    rig._switch()
                    rig._next_event = rig.schedule.next_event_after(rig.t_s + 1e-9)
            t = rig.truth()
            out[k, 3 * j : 3 * j + 3] = (t.T_sensor_true_C, t.T_pad_C, t.T_surface_C)
    return out


def _bdf_segment(rig, I: float, dt: float, rtol: float, atol: float) -> None:
    cfg = rig.cfg
    sysm = cfg.system
    n = sysm.n
    key = ("bdf", I)
    cache = getattr(cfg, "_bdf_cache", None)
    if cache is None:
        cache = cfg._bdf_cache = {}
    tem = rig.params.tem
    a, hT, J = tem.alpha_V_K * I, 0.5 * tem.tau_V_K * I, 0.5 * tem.R_ohm * I * I
    if key not in cache:
        Kc = sysm.K.copy()
        s = sysm.s.copy()
        # plate heats u = U·[Ts, Tp] + w enter the sink plate (1) and pad plate (2) rows
        Kc[1, 1] += -a + hT
        Kc[1, 2] += -hT
        Kc[2, 1] += -hT
        Kc[2, 2] += a + hT
        s[1] += -a * KELVIN + J
        s[2] += a * KELVIN + J
        A = Kc / sysm.C[:, None]
        b = s / sysm.C
        cache[key] = (A, b)
    A, b = cache[key]
    sol = solve_ivp(lambda t, x: A @ x + b, (0.0, dt), rig.x[:n], method="BDF", jac=A, rtol=rtol, atol=atol)
    rig.x[:n] = sol.y[:, -1]


def run(quick: bool = False) -> dict:
    scene = scene_10s()
    repeats = 3 if quick else 5
    print(
        f"sim benchmark: {SCENE} first {DURATION_S:g} s, two rigs, period {scene.period_s * 1e3:g} ms "
        f"({'quick' if quick else 'full'})"
    )
    ref = run_sim(scene, grid=REFINED, substeps=10)
    table = _grid_table(scene, ref, quick, repeats)
    default = table["default/1"]
    # the per-call run without building (what a long session sees) for information
    # ---- pruning
    pruning_speedup, t_unpruned, t_pruned = paired_ratio(
        lambda: run_sim(scene, prune=False, record=False), lambda: run_sim(scene, record=False), repeats
    )
    unpruned = run_sim(scene, prune=False)
    pruned = run_sim(scene)
    pruning_err = max_err(pruned, unpruned)
    print_table(
        ["variant", "wall s", "max |Δ| vs other °C"],
        [["pruned (default)", t_pruned, pruning_err], ["unpruned", t_unpruned, pruning_err]],
    )
    # ---- solve_ivp BDF baseline
    bdf_dur = 2.0 if quick else DURATION_S
    nb = int(round(bdf_dur / scene.period_s))
    ref_b = ref[:nb]
    ours_b = run_sim(scene, duration_s=bdf_dur)
    our_err_b = max_err(ours_b, ref_b)
    t_ours_b = median_time_s(lambda: run_sim(scene, duration_s=bdf_dur, record=False), repeats=repeats)
    bdf_rows, bdf = [], []
    bdf_repeats = 1 if quick else 3
    for rtol in (1e-3, 1e-4, 1e-5, 1e-6):
        atol = rtol * 1e-2
        res = run_bdf(scene, rtol, atol, bdf_dur)
        e = max_err(res, ref_b)
        ratio, tb, _ = paired_ratio(
            lambda: run_bdf(scene, rtol, atol, bdf_dur),
            lambda: run_sim(scene, duration_s=bdf_dur, record=False),
            bdf_repeats,
        )
        bdf.append({"rtol": rtol, "atol": atol, "wall_s": tb, "max_error_C": e, "time_ratio_vs_sim": ratio})
        bdf_rows.append([f"BDF rtol={rtol:g}", tb, e, ratio])
    bdf_rows.append(["sim (default)", t_ours_b, our_err_b, 1.0])
    print_table(["integrator", f"wall s ({bdf_dur:g} s scene)", "max error °C", "time / sim's"], bdf_rows)
    eligible = [b for b in bdf if b["max_error_C"] <= 1.1 * our_err_b]
    chosen = max(eligible, key=lambda b: b["rtol"]) if eligible else min(bdf, key=lambda b: b["max_error_C"])
    speedup = chosen["time_ratio_vs_sim"]
    result = {
        "scene": SCENE,
        "duration_s": DURATION_S,
        "period_s": scene.period_s,
        "rigs": 2,
        "quick": quick,
        "realtime_factor": default["realtime_factor"],
        "max_error_C": default["max_error_C"],
        "speedup_vs_solve_ivp": speedup,
        "solve_ivp_equal_error": {
            "rtol": chosen["rtol"],
            "max_error_C": chosen["max_error_C"],
            "sim_max_error_C": our_err_b,
            "window_s": bdf_dur,
            "equal_error_found": bool(eligible),
        },
        "pruning_speedup": pruning_speedup,
        "pruning_max_error_C": pruning_err,
        "settings": table,
        "solve_ivp": bdf,
        "targets": {"realtime_factor": 200.0, "max_error_C": 0.05, "speedup_vs_solve_ivp": 10.0},
        "pruning_report": {r: sim.build_rig(scene, r).pruning_report() for r in ("master", "slave")},
    }
    print(
        f"realtime_factor {result['realtime_factor']:.0f}x  max_error_C {result['max_error_C']:.4f}  "
        f"speedup_vs_solve_ivp {speedup:.1f}x (BDF rtol {chosen['rtol']:g})  pruning_speedup "
        f"{pruning_speedup:.2f}x (Δ {pruning_err:.1e} °C)"
    )
    path = write_results("sim", result)
    print(f"wrote {path}")
    return result


def _grid_table(scene, ref: np.ndarray, quick: bool, repeats: int) -> dict[str, dict[str, float]]:
    """Each grid preset and substep count against the refined reference ``ref`` (°C): wall time, s,
    real-time factor and max error, °C; printed as a table."""
    rows, table = [], {}
    for gname, grid in GRIDS.items():
        for sub in (1, 2):
            if quick and sub == 2 and gname != "default":
                continue
            res = run_sim(scene, grid=grid, substeps=sub)
            t = median_time_s(lambda: run_sim(scene, grid=grid, substeps=sub, record=False), repeats=repeats)
            err = max_err(res, ref)
            table[f"{gname}/{sub}"] = {
                "wall_s": t,
                "wall_per_sim_s": t / DURATION_S,
                "realtime_factor": DURATION_S / t,
                "max_error_C": err,
                "recorded_preset_error_C": GRID_PRESETS[gname][3],
            }
            rows.append([gname, f"{scene.period_s / sub * 1e3:g} ms", t / DURATION_S, DURATION_S / t, err])
    print_table(["grid", "step", "wall s per sim s", "x real time", "max error °C"], rows)
    return table


def plot(result: dict, out_dir: str) -> list[str]:
    """PNG figures (needs matplotlib, the 'plot' extra): error against wall time per simulated second for the
    grid/step settings and the solve_ivp baseline; and the probe scene's first 10 s (truth of both rigs with
    the direct-touch reference, no controller: open-loop currents)."""
    import os

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    os.makedirs(out_dir, exist_ok=True)
    paths = []
    fig, ax = plt.subplots(figsize=(6, 4))
    for name, row in result["settings"].items():
        ax.loglog(row["wall_per_sim_s"], row["max_error_C"], "o", label=f"sim {name}")
    w = result["solve_ivp_equal_error"]["window_s"]
    for b in result["solve_ivp"]:
        ax.loglog(b["wall_s"] / w, b["max_error_C"], "s", mfc="none", label=f"BDF rtol {b['rtol']:g}")
    ax.axhline(0.05, ls=":", c="k")
    ax.set_xlabel("wall time per simulated second, s (two rigs)")
    ax.set_ylabel("max error vs refined reference, °C")
    ax.legend(fontsize=7)
    fig.tight_layout()
    paths.append(os.path.join(out_dir, "sim_error_vs_time.png"))
    fig.savefig(paths[-1], dpi=120)
    plt.close(fig)

    scene = scene_10s()
    rigs = [sim.build_rig(scene, r) for r in ("master", "slave")]
    ref = sim.build_reference(scene)
    n = int(round(DURATION_S / scene.period_s))
    I = currents(n, scene.period_s)
    rows = []
    for k in range(n):
        for j, rig in enumerate(rigs):
            rig.apply_current(I[k] if j == 0 else -I[k])
            rig.advance(scene.period_s)
        ref.advance(scene.period_s)
        tm, ts = rigs[0].truth(), rigs[1].truth()
        rows.append(
            (
                tm.t_s,
                rigs[0].read().T_sensor_C,
                tm.T_surface_C,
                rigs[1].read().T_sensor_C,
                ts.T_surface_C,
                ref.T_contact_C,
            )
        )
    a = np.array(rows)
    fig, ax = plt.subplots(figsize=(7, 4))
    for col, lab in (
        (1, "master T_sensor (measured)"),
        (2, "master finger surface (truth)"),
        (3, "slave T_sensor (measured)"),
        (4, "slave object surface (truth)"),
        (5, "reference: finger touching directly"),
    ):
        ax.plot(a[:, 0], a[:, col], lw=1, label=lab)
    ax.set_xlabel("t, s")
    ax.set_ylabel("°C")
    ax.set_title(f"{SCENE}, open-loop ±1.5 A (no controller)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    paths.append(os.path.join(out_dir, "sim_probe_scene.png"))
    fig.savefig(paths[-1], dpi=120)
    plt.close(fig)
    return paths


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.sim_bench", description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="shorter baseline window and fewer repeats (< 30 s)")
    ap.add_argument("--plot", metavar="DIR", help="also write PNG figures into DIR (needs matplotlib)")
    args = ap.parse_args(argv)
    result = run(quick=args.quick)
    if args.plot:
        for p in plot(result, args.plot):
            print(f"wrote {p}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
