"""Material identification on the slave (issue 15): effusivity and class from the first 0.3 s of a touch.

``python -m bench.material_id_bench [--quick]`` merges its keys into ``bench/results/material_id.json``
(the coordinator merges them into ``bench/results/rendering.json``). The envelope run (``--envelope``) owns
the keys issue 23 names there; this run writes its own figure of those as ``material_id_box_*``
(:func:`box_keys`), so the two runs keep each other's keys in either order.

Each touch: the default simulated probe (sim/data/tem_15x15.toml, 10 ms, measurement noise on, 5 Hz
filter) rests in air at the finger's natural skin temperature (the pair has been running before: the
scene start ``"finger"``) under the slave's default controller (telepresence, peer = the finger at that
temperature), then touches a slab of one of the ten materials, drawn at random: contact force 2–10 N,
object temperature 15–35 °C, thickness 1–20 mm (uniform), adiabatic back. Only the first 0.6 s after the
touch is simulated (the result is published 0.5 s after it). The estimator (telethermo.control.material_id)
sees what the slave's control core sees: the filtered T_sensor and Q and the rig's contact flag.

Figures: accuracy over all touches of the class the slave's core published (a touch without an estimate counts
as wrong; with the shipped calibration, telethermo/data/material_classifier.npz, built by
bench/material_calibrate.py from reference touches of other seeds: a calibration of unknown or overlapping
seeds is refused), the physics estimator's alone (``material_id_accuracy_physics``), both again on a held-out
set of other seeds (``material_id_accuracy_heldout``), the confusion matrix
(rows: truth, columns: estimate, last column: no estimate), the median |error| of the effusivity, the
accuracy with the pairs merged that this probe cannot tell apart (mutual confusion ≥ ``MERGE_RATE`` in
this run), and two baselines in the same run: always the most frequent class, and eq. 1 inverted with the
probe's surface estimate at 0.3 s, the flux sensor's effusivity and the object assumed at ambient (the
slave does not know the object's temperature).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from bench import material_id_envelope as envelope  # its --envelope run (it uses this module's touches)
from bench.common import current_results_dir, print_table, write_results
from telethermo.offline.material_oracle import bound_figures
from telethermo.sim.materials import material
from telethermo.sim.tem import load_rig_params
from telethermo.control import material_id as mi
from telethermo.control.estimators import estimate_flux
from telethermo.control.material_stream import (
    UNKNOWN_CODE,
    MaterialEstimate,
    MaterialIdParams,
    calibrated,
    default_classes,
    early_samples,
    fit_units,
)

# the touches and the sets' seeds live in the library (the tests use them too); re-exported for the benchmarks
from telethermo.offline.material_touches import CALIBRATION  # noqa: F401  (bench/material_calibrate.py)
from telethermo.offline.material_touches import (
    AMBIENT_C,
    EVALUATION,
    EVALUATION_N,
    HELDOUT,
    HELDOUT_N,
    PERIOD_S,
    POST_S,
    PRE_S,
    SIM_TO_TABLE,
    draws,
    finger_natural_C,
    refuse_overlap,
    simulate_touch,
)

MERGE_RATE = 0.2


def check_calibration(p: MaterialIdParams) -> str:
    """What classifies in this run ("calibrated"/"physics"); refuses a calibration of unknown or overlapping
    seeds."""
    if not calibrated(p, PERIOD_S):
        return "physics"
    try:
        info = json.loads(p.calibration.info)
        n, seeds = int(info["reference_touches"]), (int(info["draw_seed"]), int(info["sim_seed_first"]))
        dense = info.get("dense") or {}
        dense_n, dense_seeds = (
            int(dense.get("touches", 0)),
            (int(dense.get("draw_seed", 0)), int(dense.get("sim_seed_first", 0))),
        )
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise ValueError(
            f"calibration of unknown origin (info {p.calibration.info[:80]!r}): refused"
        ) from exc
    refuse_overlap(n, seeds)
    if dense_n:
        refuse_overlap(dense_n, dense_seeds)
    return "calibrated"


def tick_figures(step_s: list[np.ndarray], fit_cycles: list[slice], batch_s: list[float]) -> dict[str, Any]:
    """The slave core's step time, same run: the median step (the anchor), per touch the worst of the cycles
    that carry the fit's units (``fit_cycles``; the median over touches: a random scheduler spike on this
    shared machine hits any cycle, the fit's work hits these), and the whole fit in one call (what the
    window's last cycle carried before the fit was spread)."""
    all_s = np.concatenate(step_s)
    med = float(np.median(all_s))
    worst_fit = float(np.median([float(np.max(s[c])) for s, c in zip(step_s, fit_cycles) if s[c].size]))
    batch = float(np.median(batch_s))
    return {
        "material_id_core_step_median_ms": round(1e3 * med, 3),
        "material_id_fit_cycle_worst_ms": round(1e3 * worst_fit, 3),
        "material_id_batch_fit_ms": round(1e3 * batch, 3),
        "material_id_core_step_max_ms": round(1e3 * float(np.max(all_s)), 3),
        "material_id_fit_cycle_worst_over_step_median": round(worst_fit / med, 1),
        "material_id_batch_fit_over_step_median": round(batch / med, 1),
        "material_id_tick_note": (
            "the fit runs spread over fit_units cycles after the early window (3 + noise_draws "
            "units of the physics fit, UNITS_PER_CYCLE a cycle, then one network layer a cycle, "
            "telethermo.control.material_stream); "
            "fit_cycle_worst: per touch the slowest "
            "of those cycles' core steps, median over touches; batch_fit: the physics fit in "
            "one call (estimate_effusivity, without the classification); core_step_max: the slowest step of "
            "the run (scheduler spikes included); wall times on this machine"
        ),
    }


def eq1_baseline(T: np.ndarray, Q: np.ndarray, i0: int, R_sensor: float, b_probe: float) -> float:
    """Eq. 1 inverted: b_obj = b_probe·(T_p0 − T_c)/(T_c − T_amb), T_c the surface estimate 0.3 s in."""
    T_p0 = estimate_flux(float(np.mean(T[i0 - 5 : i0])), float(np.mean(Q[i0 - 5 : i0])), R_sensor)
    k = i0 + int(round(0.3 / PERIOD_S)) - 1
    T_c = estimate_flux(float(T[k]), float(Q[k]), R_sensor)
    den = T_c - AMBIENT_C
    b = b_probe * (T_p0 - T_c) / den if abs(den) > 1e-6 else math.nan
    return b if b > 0 else math.nan


def nearest(b: float, names: list[str], lb: np.ndarray) -> int:
    """Index of the nearest table effusivity in ln b, or -1 (no estimate)."""
    return int(np.argmin(np.abs(lb - math.log(b)))) if math.isfinite(b) and b > 0 else -1


def published_index(est: MaterialEstimate | None, names: list[str]) -> int:
    """Index in ``names`` of the material the slave's core published for the touch, or -1 (none)."""
    if est is None or est.touch != 1 or est.code in (0, UNKNOWN_CODE):
        return -1
    name = {code: n for code, n, _ in default_classes()}[est.code]
    return names.index(name) if name in names else -1


def merged_groups(conf: np.ndarray, rate: float) -> list[list[int]]:
    """Connected groups of classes whose mutual confusion (c_ij + c_ji)/(n_i + n_j) is ≥ ``rate``."""
    k = conf.shape[0]
    n = conf[:, :k].sum(axis=1) + conf[:, k:].sum(axis=1)
    parent = list(range(k))

    def root(i: int) -> int:
        while parent[i] != i:
            i = parent[i]
        return i

    for i in range(k):
        for j in range(i + 1, k):
            if n[i] + n[j] and (conf[i, j] + conf[j, i]) / (n[i] + n[j]) >= rate:
                parent[root(j)] = root(i)
    groups: dict[int, list[int]] = {}
    for i in range(k):
        groups.setdefault(root(i), []).append(i)
    return sorted(groups.values())


def pair_table(conf: np.ndarray, names: list[str], lb: np.ndarray, ln_err: list[list[float]]) -> list[dict]:
    """Neighbours in ln b: their separation, the measured spread of the estimate (median |ln(b_est/b)| and
    its RMS, over both classes' touches) and the mutual confusion: a pair whose separation is below ~2
    spreads cannot be told apart by this probe in the window."""
    order = np.argsort(lb)
    out = []
    for a, b in zip(order, order[1:]):
        e = ln_err[a] + ln_err[b]
        n = conf[a].sum() + conf[b].sum()
        out.append(
            {
                "pair": [names[a], names[b]],
                "separation_ln_b": round(float(lb[b] - lb[a]), 3),
                "median_abs_ln_error": round(float(np.median(np.abs(e))), 3) if e else None,
                "rms_ln_error": round(float(np.sqrt(np.mean(np.square(e)))), 3) if e else None,
                "mutual_confusion": round(float((conf[a, b] + conf[b, a]) / n), 3) if n else None,
            }
        )
    return out


def by_condition(touches: list[tuple[bool, float, float, float, bool]]) -> dict[str, dict[str, float]]:
    """Accuracy (and count) where the physics helps or not: temperature difference probe-object, contact
    force (≥ 6 N: the simulated contact resistance vanishes), thickness, metals (b > 10⁴)."""
    conds = {
        "dT_gt_5C": lambda t: t[2] > 5.0,
        "dT_le_5C": lambda t: t[2] <= 5.0,
        "force_ge_6N": lambda t: t[1] >= 6.0,
        "force_lt_6N": lambda t: t[1] < 6.0,
        "thickness_ge_8mm": lambda t: t[3] >= 8e-3,
        "thickness_lt_8mm": lambda t: t[3] < 8e-3,
        "non_metals": lambda t: not t[4],
        "metals": lambda t: t[4],
        "non_metals_dT_gt_5C": lambda t: not t[4] and t[2] > 5.0,
        "metals_force_ge_6N_thickness_ge_8mm": lambda t: t[4] and t[1] >= 6.0 and t[3] >= 8e-3,
    }
    out = {}
    for name, f in conds.items():
        sel = [t[0] for t in touches if f(t)]
        out[name] = {"accuracy": round(float(np.mean(sel)), 3) if sel else None, "n": len(sel)}
    return out


def heldout_figures(params, T_probe: float, names: list[str], lb: np.ndarray, n: int) -> dict[str, Any]:
    """Accuracy of what the slave publishes and of the physics estimator alone on ``n`` held-out touches (same
    distribution, other seeds: :data:`HELDOUT`), each with its standard error √(p(1−p)/n), and whether the
    published one beats the physics one by more than two of them."""
    sims = list(SIM_TO_TABLE)
    ok, ok_phys = [], []
    for dr in draws(n, HELDOUT):
        T, Q, i0, est, _ = simulate_touch(
            params,
            sims[dr["class"]],
            dr["thickness_m"],
            dr["T_object_C"],
            dr["force_N"],
            T_probe,
            seed=dr["seed"],
            t_on_s=dr["t_on_s"],
        )
        phys = mi.estimate_effusivity(T, Q, i0, PERIOD_S)
        ok.append(published_index(est, names) == dr["class"])
        ok_phys.append(nearest(phys.b if phys is not None else math.nan, names, lb) == dr["class"])
    p, q = float(np.mean(ok)), float(np.mean(ok_phys))
    se = math.sqrt(max(q * (1 - q), 1e-12) / n)
    return {
        "material_id_accuracy_heldout": p,
        "material_id_accuracy_physics_heldout": q,
        "material_id_heldout_se": round(math.sqrt(p * (1 - p) / n), 4),
        "material_id_physics_heldout_se": round(se, 4),
        "material_id_heldout_gain_over_2se": bool(p - q > 2.0 * se),
        "material_id_heldout": {
            "n": n,
            "draw_seed": HELDOUT[0],
            "sim_seed_first": HELDOUT[1],
            "note": "same distribution as the evaluation touches, other seeds; not used to "
            "build or tune anything",
        },
    }


def material_id_figures(quick: bool) -> dict[str, Any]:
    """Run the touches and return the figures (see the module docstring)."""
    t_start = time.perf_counter()
    n_touches = 150 if quick else EVALUATION_N
    method = check_calibration(MaterialIdParams())
    params = load_rig_params()
    T_probe = finger_natural_C(params)
    table = mi.load_effusivity_table()
    sims = list(SIM_TO_TABLE)
    names = [SIM_TO_TABLE[m] for m in sims]
    lb = np.log(np.array([table[n] for n in names]))
    r = _run_touches(n_touches, params, T_probe, sims, names, lb)
    k = len(names)
    correct = int(np.trace(r.conf[:, :k]))
    groups = merged_groups(r.conf, MERGE_RATE)
    group_of = {c: gi for gi, g in enumerate(groups) for c in g}
    merged_ok = sum(int(r.conf[a, b]) for a in range(k) for b in range(k) if group_of[a] == group_of[b])
    majority = float(r.conf.sum(axis=1).max() / n_touches)
    pairs = pair_table(r.conf, names, lb, r.ln_err)
    bound = bound_figures(params, sims, r.draw_list, T_probe, PERIOD_S, AMBIENT_C, [t[0] for t in r.touches])
    held = heldout_figures(params, T_probe, names, lb, 150 if quick else HELDOUT_N)
    return (
        bound
        | held
        | tick_figures(r.step_s, r.fit_cycles, r.batch_s)
        | {
            "material_id_accuracy": correct / n_touches,
            "material_id_method": method,
            "material_id_accuracy_physics": float(np.trace(r.conf_phys[:, :k]) / n_touches),
            "confusion_physics": r.conf_phys.tolist(),
            "material_id_n_touches": n_touches,
            "effusivity_error_median_pct": float(np.median(r.err_pct)) if r.err_pct else math.nan,
            "material_id_no_estimate": int(r.conf[:, k].sum()),
            "material_id_ci95_coverage": float(np.mean(r.within_ci)) if r.within_ci else math.nan,
            "material_id_se_ln_b_median": float(np.median(r.se_ln)) if r.se_ln else math.nan,
            "confusion": {
                "labels": names,
                "columns": names + ["none"],
                "rows_truth_cols_estimate": r.conf.tolist(),
            },
            "material_id_merged_groups": [[names[c] for c in g] for g in groups if len(g) > 1],
            "material_id_pairs": pairs,
            "material_id_accuracy_by_condition": by_condition(r.touches),
            "material_id_merge_rule": f"pairs with mutual confusion >= {MERGE_RATE} in this run, "
            "joined transitively",
            "material_id_accuracy_merged": merged_ok / n_touches,
            "material_id_baseline_majority_accuracy": majority,
            "material_id_baseline_eq1_ambient_accuracy": float(np.trace(r.conf_eq1[:, :k]) / n_touches),
            "confusion_eq1_baseline": r.conf_eq1.tolist(),
            "material_id_conditions": {
                "force_N": [2.0, 10.0],
                "T_object_C": [15.0, 35.0],
                "thickness_mm": [1.0, 20.0],
                "T_probe_C": round(T_probe, 3),
                "window_s": mi.ProbeParams().window_s,
                "simulated_s_per_touch": PRE_S + POST_S,
                "noise": "sim default (on)",
            },
            "material_id_run_s": round(time.perf_counter() - t_start, 1),
        }
    )


@dataclass
class _Run:
    """What the evaluation touches gave: the confusion matrices (truth x estimate, last column: none) of
    the published answer, of the physics fit alone and of the eq. 1 baseline; the effusivity errors, %,
    CI coverage and standard errors of ln b; per touch (right, force N, |ΔT| °C, thickness m, metal), its
    draw, the core's step times, s, its fit cycles and the batch fit's time, s."""

    conf: np.ndarray
    conf_phys: np.ndarray
    conf_eq1: np.ndarray
    err_pct: list[float]
    within_ci: list[bool]
    se_ln: list[float]
    ln_err: list[list[float]]
    touches: list[tuple[bool, float, float, float, bool]]
    draw_list: list[dict]
    step_s: list[np.ndarray]
    batch_s: list[float]
    fit_cycles: list[slice]


def _run_touches(
    n_touches: int, params, T_probe: float, sims: list, names: list[str], lb: np.ndarray
) -> _Run:
    """The evaluation touches (draws :data:`EVALUATION`), each simulated and classified three ways."""
    R_sensor = 2.0 * mi.ProbeParams().R_half_K_per_W
    b_probe = material(params.sensor_material).b
    k = len(names)
    conf = np.zeros((k, k + 1), int)
    conf_phys = np.zeros((k, k + 1), int)
    conf_eq1 = np.zeros((k, k + 1), int)
    err_pct, within_ci, se_ln = [], [], []
    ln_err: list[list[float]] = [[] for _ in range(k)]
    touches: list[tuple[bool, float, float, float, bool]] = []  # (right, force, |ΔT|, thickness, metal)
    draw_list: list[dict] = []
    step_s: list[np.ndarray] = []
    batch_s: list[float] = []
    fit_cycles: list[slice] = []
    n_win, units = early_samples(MaterialIdParams(), PERIOD_S), fit_units(MaterialIdParams(), PERIOD_S)
    for dr in draws(n_touches, EVALUATION):
        j, force, T_obj, d, t_on = (
            dr["class"],
            dr["force_N"],
            dr["T_object_C"],
            dr["thickness_m"],
            dr["t_on_s"],
        )
        mat = sims[j]
        T, Q, i0, est, st_s = simulate_touch(
            params, mat, d, T_obj, force, T_probe, seed=dr["seed"], t_on_s=t_on
        )
        step_s.append(st_s)
        fit_cycles.append(slice(i0 + n_win, i0 + n_win + units))
        t0 = time.perf_counter()
        phys = mi.estimate_effusivity(T, Q, i0, PERIOD_S)
        batch_s.append(time.perf_counter() - t0)
        conf_phys[j, nearest(phys.b if phys is not None else math.nan, names, lb)] += 1
        draw_list.append(dr)
        b_true = material(mat).b
        b_est = est.effusivity if est is not None and est.touch == 1 else math.nan
        got = published_index(est, names)
        if math.isfinite(b_est):
            err_pct.append(100.0 * abs(b_est / b_true - 1.0))
            within_ci.append(abs(math.log(b_est / b_true)) <= 1.96 * est.se_ln_b)
            se_ln.append(est.se_ln_b)
            ln_err[j].append(math.log(b_est / b_true))
        conf[j, got] += 1
        touches.append((got == j, force, abs(T_obj - T_probe), d, b_true > 10_000.0))
        conf_eq1[j, nearest(eq1_baseline(T, Q, i0, R_sensor, b_probe), names, lb)] += 1
    return _Run(
        conf,
        conf_phys,
        conf_eq1,
        err_pct,
        within_ci,
        se_ln,
        ln_err,
        touches,
        draw_list,
        step_s,
        batch_s,
        fit_cycles,
    )


def print_material_id(fig: dict[str, Any]) -> None:
    """The confusion matrix and the headline figures."""
    c = fig["confusion"]
    rows = [[n] + row for n, row in zip(c["labels"], c["rows_truth_cols_estimate"])]
    print_table(["truth \\ est"] + c["columns"], rows)
    for key in (
        "material_id_method",
        "material_id_accuracy",
        "material_id_accuracy_physics",
        "material_id_accuracy_heldout",
        "material_id_accuracy_physics_heldout",
        "material_id_accuracy_bound",
        "material_id_accuracy_bound_known_nuisance",
        "material_id_unidentifiable_fraction",
        "material_id_accuracy_identifiable",
        "material_id_accuracy_merged",
        "material_id_merged_groups",
        "effusivity_error_median_pct",
        "material_id_baseline_majority_accuracy",
        "material_id_baseline_eq1_ambient_accuracy",
        "material_id_ci95_coverage",
        "material_id_run_s",
    ):
        print(f"{key}: {fig[key]}")


def run(quick: bool) -> dict[str, Any]:
    """Figures, printed table, bench/results/material_id.json (``python -m bench.material_id_bench``; the
    suite runs them inside the rendering benchmark, into rendering.json)."""
    fig = material_id_figures(quick)
    print_material_id(fig)
    path = current_results_dir() / "material_id.json"
    old = json.loads(path.read_text()) if path.exists() else {}
    print(f"wrote {write_results('material_id', old | box_keys(fig))}")
    return fig


def box_keys(fig: dict[str, Any]) -> dict[str, Any]:
    """``fig`` for material_id.json: the keys issue 23 gave to the envelope run
    (:data:`bench.material_id_envelope.ENVELOPE_OWNS`) renamed ``material_id_box_*``, so that neither run
    overwrites the other's figure whatever order they run in (the rest of the file is kept)."""
    return {
        (k.replace("material_id_", "material_id_box_", 1) if k in envelope.ENVELOPE_OWNS else k): v
        for k, v in fig.items()
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.material_id_bench", description=__doc__)
    ap.add_argument("--quick", action="store_true", help="150 touches instead of 600")
    ap.add_argument(
        "--envelope",
        action="store_true",
        help="the envelope's touches instead (issue 23, "
        "bench/material_id_envelope.py): its keys merged into material_id.json",
    )
    args = ap.parse_args(argv)
    if args.envelope:
        envelope.run(args.quick)
        return 0
    run(args.quick)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
