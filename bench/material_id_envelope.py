"""Material identification across the operating envelope (issue 23): accuracy, abstains and honest confidence.

``python -m bench.material_id_bench --envelope [--quick]`` (or ``python -m bench.material_id_envelope``)
merges the ``material_id_envelope_*`` keys into ``bench/results/material_id.json``.

Touches (:func:`envelope_draws`, seeds :data:`ENVELOPE`, disjoint from the calibration's, the evaluation's and
the held-out set's: :func:`check_seeds`): the ten materials in turn; object 5–50 °C, room 15–32 °C (uniform);
force 0.5–20 N and thickness 0.3–20 mm (log-uniform, so that the low strata are populated); the rig's sensor
noise × 1–3; one touch in four with another probe TEM (:func:`other_tem`: 71 couples instead of 31, the
same pellets), whose slave runs what ``telethermo identify`` on it gives (:func:`after_identify`: the
identified model's gains, and the classifier's box told it is another module), as issue 23 asks; the probe
resting at the finger's natural temperature in that room (where the slave's controller leaves it), as
bench/material_id_bench.py otherwise.

Figures per stratum (:data:`STRATA`; the band within :data:`NEAR_C` °C of the probe is its own stratum and is
left out of the others, where a passive probe learns little): accuracy with abstains counted wrong, abstain
fraction, expected calibration error of the answers (10 bins of the published posterior; beside the worst
stratum's, the worst-stratum ECE a perfectly calibrated classifier shows on the same answers,
``material_id_ece_worst_stratum_floor_calibrated``), confident
precision (accuracy of the answers with posterior ≥ 0.9, with their count), the commonest-class baseline and,
in the full run, the oracle of telethermo/offline/material_oracle.py (knows the simulator; object
temperature, contact resistance and thickness profiled out) over each answer's own window on a sample of the
stratum's touches (bench/material_envelope_oracle.py), and the accuracy with the pairs that oracle cannot
tell apart merged, beside. The same keys on in-box touches (the bench's evaluation draws) for comparison.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from dataclasses import replace
from typing import Any, Callable, cast

import numpy as np

from bench import material_id_bench as mb
from bench.common import current_results_dir, write_results
from bench.material_envelope_oracle import add_oracle, merged_keys, oracle_note, oracle_sampled
from bench.material_id_scores import (
    CONFIDENT,
    answer_timing,
    ece,
    ece_floor,
    ece_worst_floor,
    outside_figures,
    position_worst_ms,
    print_envelope,
)
from telethermo.control.types import Role
from telethermo.offline.envelope import identified_params
from telethermo.control.material_stream import (
    MaterialIdParams,
    UNKNOWN_CODE,
    early_samples,
    fit_units,
    late_fit_units,
    late_samples,
)
from telethermo.sim.materials import material
from telethermo.sim.tem import load_rig_params

# the envelope's touches live in the library (the tests draw them too); re-exported for the calibration
from telethermo.offline.material_touches import (
    ENVELOPE,
    ENVELOPE_N,
    OTHER_TEM_COUPLES,
    OUTSIDE,
    envelope_draws,
    noise_of,
    other_tem,
    outside_draws,
)

#: the envelope's touches of the quick run (the full run's seeds and size, ENVELOPE and ENVELOPE_N, and the
#: development set's, DEVELOPMENT, are telethermo.offline.material_touches')
ENVELOPE_QUICK_N = 250
INBOX_N, INBOX_QUICK_N = 300, 100
#: touches with one condition beyond the envelope (material_touches.outside_draws), full and quick run
OUTSIDE_N, OUTSIDE_QUICK_N = 200, 50
NEAR_C = 2.0
#: the seed of the other TEM's identification (as tests/control/test_material_tem_swap.py's)
IDENTIFY_SEED = 7
#: simulated after the touch, s: the refined answer (1.2 s window, its fit, both networks) is out by 1.27 s
POST_S = 1.45
#: keys of material_id.json that issue 23 names for this run and the in-box run (bench/material_id_bench.py)
#: also computes: that run writes its own as ``material_id_box_*`` (material_id_bench.box_keys)
ENVELOPE_OWNS = frozenset(
    {
        "material_id_ci95_coverage",
        "material_id_fit_cycle_worst_ms",
        "material_id_core_step_median_ms",
        "material_id_fit_cycle_worst_over_step_median",
    }
)

STRATA: dict[str, Callable[[dict], bool]] = {
    "object_lt_15C": lambda t: t["T_object_C"] < 15.0,
    "object_15_35C": lambda t: 15.0 <= t["T_object_C"] <= 35.0,
    "object_gt_35C": lambda t: t["T_object_C"] > 35.0,
    "force_lt_2N": lambda t: t["force_N"] < 2.0,
    "thickness_lt_1mm": lambda t: t["thickness_m"] < 1e-3,
    "room_lt_20C": lambda t: t["ambient_C"] < 20.0,
    "room_gt_28C": lambda t: t["ambient_C"] > 28.0,
    "other_tem": lambda t: t["other_tem"],
    "noise_gt_x2": lambda t: t["noise_x"] > 2.0,
    "object_force_thickness_tem_in_box": lambda t: (
        15.0 <= t["T_object_C"] <= 35.0
        and 2.0 <= t["force_N"] <= 10.0
        and 1e-3 <= t["thickness_m"] <= 20e-3
        and not t["other_tem"]
    ),
}


def check_seeds(p: MaterialIdParams, n: int, seeds: tuple[int, int]) -> None:
    """ValueError when ``n`` touches of ``seeds`` meet the calibration's references, the bench's evaluation or
    its held-out touches (by draw seed or simulator seed range): nothing trained or tuned on them is
    reported."""
    ranges = [(mb.EVALUATION, mb.EVALUATION_N), (mb.HELDOUT, mb.HELDOUT_N)]
    if p.calibration is not None:
        info = json.loads(p.calibration.info)
        ranges.append(((int(info["draw_seed"]), int(info["sim_seed_first"])), int(info["reference_touches"])))
        d = info.get("dense") or {}
        if d:
            ranges.append(((int(d["draw_seed"]), int(d["sim_seed_first"])), int(d["touches"])))
    for env in (p.envelope, p.envelope_late):  # the envelope classifiers' reference touches
        if env is not None:
            info = json.loads(env.info)
            ranges.append(
                ((int(info["draw_seed"]), int(info["sim_seed_first"])), int(info["reference_touches"]))
            )
    for (draw, first), m in ranges:
        if seeds[0] == draw or (seeds[1] < first + m and seeds[1] + n > first):
            raise ValueError(
                f"envelope seeds {seeds} (n {n}) meet another set's {(draw, first)} (n {m}): refused"
            )


def simulate_drawn(
    rigs: dict,
    t: dict,
    sims: list[str],
    cores: dict | None = None,
    post_s: float = POST_S,
    identify: bool = True,
) -> tuple:
    """material_touches.simulate_touch of drawn touch ``t`` (its material, object, force, onset, noise, room)
    on ``rigs[t["other_tem"]]``, the probe resting at the finger's natural temperature in that room;
    ``cores``: the slave core's parameters per ``other_tem`` (None: its defaults)."""
    params = rigs[t["other_tem"]]
    return mb.simulate_touch(
        params,
        sims[t["class"]],
        t["thickness_m"],
        t["T_object_C"],
        t["force_N"],
        mb.finger_natural_C(params, t["ambient_C"]),
        seed=t["seed"],
        t_on_s=t["t_on_s"],
        identify=identify,
        noise=noise_of(t["noise_x"]),
        ambient_C=t["ambient_C"],
        post_s=post_s,
        core_params=(cores or {}).get(t["other_tem"]),
    )


def run_touch(rigs: dict, t: dict, sims: list[str], names: list[str], cores: dict | None = None) -> dict:
    """Simulate one touch and return what the slave published, scored (``answer`` −1: none, −2: abstained).
    ``cores``: the slave core's parameters per ``other_tem`` (None: its defaults)."""
    T_probe = mb.finger_natural_C(rigs[t["other_tem"]], t["ambient_C"])
    _, _, i0, est, step_s = simulate_drawn(rigs, t, sims, cores)
    b_true = material(sims[t["class"]]).b
    ok_b = est is not None and math.isfinite(est.effusivity) and math.isfinite(est.se_ln_b)
    early = replace(est, code=est.early_code, posterior=est.early_posterior) if est is not None else None
    return t | {
        "T_probe_C": T_probe,
        "answer": _answer(est, names),
        "posterior": _post(est),
        "answer_early": _answer(early, names),
        "posterior_early": _post(early),
        "stage": est.stage if est is not None else "",
        "within_ci95": (abs(math.log(est.effusivity / b_true)) <= 1.96 * est.se_ln_b) if ok_b else None,
        "fit_step_ms": _fit_cycles_ms(step_s, i0),
        "fit_positions_ms": _fit_positions_ms(step_s, i0),
        "step_median_ms": 1e3 * float(np.median(step_s)),
    }


def _answer(est, names: list[str]) -> int:
    """Index of the published material in ``names``, −2 "unknown", −1 none."""
    if est is not None and est.touch == 1 and est.code == UNKNOWN_CODE:
        return -2
    return mb.published_index(est, names)


def _post(est) -> float:
    return float(est.posterior) if est is not None else 0.0


def _fit_cycles_ms(step_s: np.ndarray, i0: int) -> tuple[float | None, float | None]:
    """The slowest core step of the cycles that carry the early fit's units, and the refined fit's, ms."""
    if i0 < 0:
        return None, None
    p = MaterialIdParams()
    n_win = early_samples(p, mb.PERIOD_S)
    cyc = [range(i0 + n_win, i0 + n_win + fit_units(p, mb.PERIOD_S) + 1)]
    n_late = late_samples(p, mb.PERIOD_S)
    if n_late:  # the window's signals, the two forms, the noise draws, the networks' layers (the pool's too)
        cyc.append(range(i0 + n_late, i0 + n_late + late_fit_units(p) + 1))
    out = [[k for k in c if k < step_s.size] for c in cyc] + [[]]
    return tuple(1e3 * float(np.max(step_s[i])) if i else None for i in out[:2])


def _fit_positions_ms(step_s: np.ndarray, i0: int) -> list[float]:
    """The core steps (ms) of the cycles that carry the early fit's units, in order (empty: no contact)."""
    if i0 < 0:
        return []
    p = MaterialIdParams()
    k0 = i0 + early_samples(p, mb.PERIOD_S)
    return [1e3 * float(v) for v in step_s[k0 : k0 + fit_units(p, mb.PERIOD_S) + 1]]


#: the early answer's figures per stratum
EARLY_KEYS = (
    "accuracy",
    "abstain_fraction",
    "ece",
    "ece_floor",
    "confident_n",
    "confident_precision",
    "oracle",
)


def stratum_figures(rows: list[dict]) -> dict[str, Any]:
    """The refined answer's accuracy (abstains wrong), abstain fraction, ECE, confident precision, baseline,
    oracle of ``rows``, and the early answer's (``early``)."""
    if not rows:
        return {"n": 0}
    early = [
        r | {"answer": r["answer_early"], "posterior": r["posterior_early"], "oracle": r.get("oracle_early")}
        for r in rows
    ]
    return _figures(rows) | {"early": {k: v for k, v in _figures(early).items() if k in EARLY_KEYS}}


def _figures(rows: list[dict]) -> dict[str, Any]:
    truth = np.array([r["class"] for r in rows])
    ans = np.array([r["answer"] for r in rows])
    post = np.array([r["posterior"] for r in rows])
    answered = ans >= 0
    right = ans == truth
    conf = answered & (post >= CONFIDENT)
    cov = [r["within_ci95"] for r in rows if r["within_ci95"] is not None]
    orc = [r["oracle"] for r in rows if r.get("oracle") is not None]
    e = ece(post[answered], right[answered])
    e_floor = ece_floor(post[answered])
    return {
        "n": len(rows),
        "accuracy": round(float(right.mean()), 3),
        "abstain_fraction": round(float(np.mean(ans == -2)), 3),
        "no_estimate_fraction": round(float(np.mean(ans == -1)), 3),
        "accuracy_of_answers": round(float(right[answered].mean()), 3) if answered.any() else None,
        "ece": round(e, 3) if e is not None else None,
        "ece_floor": round(e_floor, 3) if e_floor is not None else None,
        "confident_n": int(conf.sum()),
        "confident_precision": round(float(right[conf].mean()), 3) if conf.any() else None,
        "ci95_coverage": round(float(np.mean(cov)), 3) if cov else None,
        "baseline_commonest_class": round(float(np.bincount(truth).max() / truth.size), 3),
        "oracle": round(float(np.mean(orc)), 3) if orc else None,
        "oracle_n": len(orc),
    }


def after_identify(params) -> Any:
    """The slave core's parameters on the rig ``params`` after ``telethermo identify`` on its free pad, once,
    in the default room (telethermo.offline.envelope.identified_params, seed :data:`IDENTIFY_SEED`): the gains
    of the identified model, and the material classifier's box told that this is another module when it is."""
    cp, fit = identified_params(Role.SLAVE, params, mb.AMBIENT_C, mb.PERIOD_S, IDENTIFY_SEED)
    if fit.get("identify_refused"):
        raise RuntimeError(f"identify refused the other TEM's model: {fit}")
    return cp


def near(r: dict) -> bool:
    """Whether touch ``r``'s object lies within NEAR_C of the probe (the near band: its own stratum)."""
    return abs(r["T_object_C"] - r["T_probe_C"]) < NEAR_C


def strata_rows(rows: list[dict]) -> dict[str, list[dict]]:
    """The touches of each stratum: the near-probe band alone, every other stratum without it, and all."""
    far = [r for r in rows if not near(r)]
    out = {"all_outside_near_band": far, f"near_probe_lt_{NEAR_C:g}C": [r for r in rows if near(r)]}
    return out | {name: [r for r in far if f(r)] for name, f in STRATA.items()}


def split(rows: list[dict]) -> dict[str, Any]:
    """Per-stratum figures (:func:`strata_rows`)."""
    return {name: stratum_figures(rs) for name, rs in strata_rows(rows).items()}


def ece_worst_floors(rows: list[dict]) -> tuple[float | None, float | None]:
    """The worst-stratum ECE a perfectly calibrated classifier would show on these touches' answers, refined
    and early (material_id_scores.ece_worst_floor over the strata :func:`worst` ranks)."""
    groups = [rs for k, rs in strata_rows(rows).items() if not k.startswith("near")]
    out = [
        ece_worst_floor([np.array([r[p] for r in rs if r[a] >= 0]) for rs in groups])
        for a, p in (("answer", "posterior"), ("answer_early", "posterior_early"))
    ]
    return tuple(round(v, 3) if v is not None else None for v in out)  # type: ignore[return-value]


def _first_rows(rows: list[dict], n: int) -> dict[str, Any]:
    """The headline figures on the first ``n`` touches (the envelope set's size before the twentieth
    session: the same touches, so the figures compare with earlier runs)."""
    strata = split(rows[:n])
    w_ece, which = worst(strata, "ece", high_is_good=False)
    return {
        "n": min(n, len(rows)),
        "accuracy_late": strata["all_outside_near_band"]["accuracy"],
        "accuracy_early": strata["all_outside_near_band"]["early"]["accuracy"],
        "worst_stratum_accuracy_late": worst(strata, "accuracy")[0],
        "ece_worst_stratum": w_ece,
        "ece_worst_stratum_which": which,
        "ece_worst_stratum_floor_calibrated": ece_worst_floors(rows[:n])[0],
    }


def worst(strata: dict[str, Any], key: str, high_is_good: bool = True) -> tuple[float | None, str | None]:
    """The worst value of ``key`` over the target strata (not the near band), and which."""
    vals = [(v[key], k) for k, v in strata.items() if not k.startswith("near") and v.get(key) is not None]
    if not vals:
        return None, None
    return (min if high_is_good else max)(vals)


def _inbox_rows(rigs: dict, sims: list[str], names: list[str], quick: bool) -> list[dict]:
    """The bench's in-box evaluation touches (the default room and noise, the shipped probe), scored."""
    inbox = [
        t | {"ambient_C": mb.AMBIENT_C, "noise_x": 1.0, "other_tem": False}
        for t in mb.draws(INBOX_QUICK_N if quick else INBOX_N, mb.EVALUATION)
    ]
    return [run_touch(rigs, t, sims, names) for t in inbox]


def _tick_keys(rows: list[dict]) -> dict[str, Any]:
    """The fit's cost on the tick: per touch the slowest fit cycle (median over touches), the slowest cycle
    position (material_id_scores.position_worst_ms), each over the median core step of the same run."""
    fit_ms = [r["fit_step_ms"][0] for r in rows if r["fit_step_ms"][0] is not None]
    late_ms = [r["fit_step_ms"][1] for r in rows if r["fit_step_ms"][1] is not None]
    step_med = float(np.median([r["step_median_ms"] for r in rows]))
    return {
        "material_id_fit_cycle_worst_ms": round(float(np.median(fit_ms)), 3),
        "material_id_core_step_median_ms": round(step_med, 3),
        "material_id_fit_cycle_worst_over_step_median": round(float(np.median(fit_ms)) / step_med, 1),
        "material_id_fit_position_worst_ms": round(cast(float, position_worst_ms(rows)), 3),
        "material_id_fit_position_worst_over_step_median": round(
            cast(float, position_worst_ms(rows)) / step_med, 1
        ),
        "material_id_late_fit_cycle_worst_ms": round(float(np.median(late_ms)), 3) if late_ms else None,
        "material_id_late_fit_cycle_worst_over_step_median": (
            round(float(np.median(late_ms)) / step_med, 1) if late_ms else None
        ),
    }


def envelope_figures(quick: bool) -> dict[str, Any]:
    """Run the envelope's and the in-box touches and return the keys (module docstring)."""
    t0 = time.perf_counter()
    p = MaterialIdParams()
    n = ENVELOPE_QUICK_N if quick else ENVELOPE_N
    check_seeds(p, n, ENVELOPE)
    base = load_rig_params()
    rigs = {False: base, True: other_tem(base)}
    sims = list(mb.SIM_TO_TABLE)
    names = [mb.SIM_TO_TABLE[m] for m in sims]
    cores = {True: after_identify(rigs[True])}
    rows = [run_touch(rigs, t, sims, names, cores) for t in envelope_draws(n, ENVELOPE)]
    in_rows = _inbox_rows(rigs, sims, names, quick)
    if not quick:
        sample = [r for i, r in enumerate(rows) if oracle_sampled(i, len(sims)) or near(r)]
        add_oracle(sample, rigs, cores, sims, seed=2323)
    n_out = OUTSIDE_QUICK_N if quick else OUTSIDE_N
    check_seeds(p, n_out, OUTSIDE)
    outside = outside_figures([run_touch(rigs, t, sims, names, cores) for t in outside_draws(n_out, OUTSIDE)])
    strata = split(rows)
    in_fig = stratum_figures([r for r in in_rows if not near(r)])
    allf = strata["all_outside_near_band"]
    w_acc, w_acc_name = worst(strata, "accuracy")
    w_ece, w_ece_name = worst(strata, "ece", high_is_good=False)
    w_cp, w_cp_name = worst(strata, "confident_precision")
    floor_late, floor_early = ece_worst_floors(rows)
    return {
        "material_id_envelope_n_touches": n,
        "material_id_envelope_accuracy_late": allf["accuracy"],
        "material_id_envelope_accuracy_early": allf["early"]["accuracy"],
        "material_id_abstain_fraction_early": allf["early"]["abstain_fraction"],
        "material_id_confident_precision_worst_stratum_early": worst(
            {k: v.get("early", {}) for k, v in strata.items()}, "confident_precision"
        )[0],
        "material_id_ece_worst_stratum_early": worst(
            {k: v.get("early", {}) for k, v in strata.items()}, "ece", high_is_good=False
        )[0],
        "material_id_ci95_coverage": allf["ci95_coverage"],
        **_tick_keys(rows),
        "material_id_abstain_fraction": allf["abstain_fraction"],
        "material_id_envelope_ece": allf["ece"],
        "material_id_envelope_confident_precision": allf["confident_precision"],
        "material_id_envelope_ci95_coverage": allf["ci95_coverage"],
        "material_id_worst_stratum_accuracy_late": w_acc,
        "material_id_worst_stratum_accuracy_late_which": w_acc_name,
        "material_id_ece_worst_stratum": w_ece,
        "material_id_ece_worst_stratum_which": w_ece_name,
        "material_id_ece_worst_stratum_floor": strata[w_ece_name]["ece_floor"] if w_ece_name else None,
        "material_id_ece_worst_stratum_floor_calibrated": floor_late,
        "material_id_ece_worst_stratum_floor_calibrated_early": floor_early,
        "material_id_ece_excess_over_floor_worst": worst(
            {
                k: v | {"excess": round(v["ece"] - v["ece_floor"], 3)}
                for k, v in strata.items()
                if v.get("ece")
            },
            "excess",
            high_is_good=False,
        )[0],
        "material_id_confident_precision_worst_stratum": w_cp,
        "material_id_confident_precision_worst_stratum_which": w_cp_name,
        "material_id_outside_n_touches": n_out,
        "material_id_outside_unknown_fraction": outside["all"]["late"]["unknown_fraction"],
        "material_id_outside_unknown_fraction_early": outside["all"]["early"]["unknown_fraction"],
        "material_id_outside_confident_precision": outside["all"]["late"]["confident_precision"],
        "material_id_outside": outside,
        "material_id_envelope_strata": strata,
        **merged_keys([r for r in rows if not near(r)], names),
        "material_id_envelope_first_1000": _first_rows(rows, 1000),
        "material_id_inbox_same_keys": in_fig
        | {"draws": f"bench evaluation draws (15, 1000 + i), first {len(in_rows)}, near-probe band left out"},
        "material_id_envelope_conditions": _conditions(quick),
        "material_id_envelope_run_s": round(time.perf_counter() - t0, 1),
    }


def _conditions(quick: bool) -> dict[str, Any]:
    """The envelope's draw conditions and what the figures mean, for the results file."""
    return {
        "draw_seed": ENVELOPE[0],
        "sim_seed_first": ENVELOPE[1],
        "T_object_C": [5.0, 50.0],
        "ambient_C": [15.0, 32.0],
        "force_N": [0.5, 20.0],
        "thickness_mm": [0.3, 20.0],
        "noise_x": [1.0, 3.0],
        "other_tem": (
            f"{OTHER_TEM_COUPLES} couples, one touch in four, the slave after identify on it "
            f"(seed {IDENTIFY_SEED})"
        ),
        "near_band_C": NEAR_C,
        "confident_posterior": CONFIDENT,
        "oracle": oracle_note() if not quick else "not run",
        "early_answer": answer_timing(early=True),
        "late_answer": answer_timing(early=False),
        "tick": "fit_cycle_worst: per touch the slowest core step of the early fit's cycles "
        "(late_: of the refined fit's), median over touches; "
        "core_step_median: median of the touches' median steps",
    }


def run(quick: bool) -> dict[str, Any]:
    """Figures merged into bench/results/material_id.json (the other keys of that file are kept)."""
    fig = envelope_figures(quick)
    print_envelope(fig)
    path = current_results_dir() / "material_id.json"
    old = json.loads(path.read_text()) if path.exists() else {}
    print(f"wrote {write_results('material_id', old | fig)}")
    return fig


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.material_id_envelope", description=__doc__)
    ap.add_argument(
        "--quick", action="store_true", help=f"{ENVELOPE_QUICK_N} touches instead of {ENVELOPE_N}"
    )
    args = ap.parse_args(argv)
    run(args.quick)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
