"""How many reference touches a lab needs to calibrate the physics fit of its own probe (issue 23).

``python -m bench.material_lab_calibrate`` (about 2 min here) -> ``bench/results/material_lab.json``.

The lab's probe is not the shipped one: its flux sensor is :data:`LAB_SENSOR_MM` thick instead of 0.42 mm,
while the physics fit keeps the shipped lumped model (telethermo.control.material_id.ProbeParams), so its bias
changes (a thicker sensor reads insulators far too high, metals about right). On each probe:

- **reference touches** (what a lab records): :data:`REFERENCES` in turn, samples 10–20 mm thick at room
  temperature 20–26 °C (the room too), 3–8 N, the rig's noise; seeds :data:`REFERENCE_SEEDS`, drawn in
  :data:`REPEATS` disjoint blocks of :data:`BLOCK` touches. A calibration from K touches (K in :data:`KS`,
  the three materials in turn) takes the first K of one block (telethermo.control.material_lab.fit_window,
  both windows), so each K is measured :data:`REPEATS` times on touches of its own;
- **evaluation touches**: :data:`EVALUATION_N` touches of the ten materials, the bench's in-box conditions
  (force 2–10 N, object 15–35 °C, thickness 1–20 mm, room 25 °C, the probe resting at the finger's natural
  temperature), seeds :data:`EVALUATION_SEEDS`; both seed sets checked disjoint from every other set's.

Scored as the slave's physics posterior publishes it (telethermo.control.material_physics.decide, the fit
over 0.3 s and 1.2 s): accuracy with abstentions counted wrong, and the coverage of the true effusivity by
the published 95 % interval (touches with a fit), before (the shipped EARLY/LATE) and after the lab's
correction (the median over the repeats, the worst and the best repeat). The top-level keys are the lab
probe's refined answer (``_early_``: the first answer; ``_shipped_``: the shipped probe's, calibrated the
same way) at the K reported. ``material_lab_touches_needed``: the smallest
K whose median refined accuracy is within :data:`ENOUGH_TOL` of the largest K's and whose interval coverage
stays in 0.90–0.98 in every repeat.
"""

from __future__ import annotations

import argparse
import math
import time
from typing import Any, cast

import numpy as np

from bench import material_id_envelope as me
from bench.common import write_results
from telethermo.control import material_lab as ml
from telethermo.control import material_physics as mp
from telethermo.control.material_id import ProbeParams, load_effusivity_table
from telethermo.control.material_stream import MaterialIdParams
from telethermo.offline.material_touches import (
    PERIOD_S,
    PRE_S,
    SIM_TO_TABLE,
    finger_natural_C,
    refuse_overlap,
    simulate_touch,
)
from telethermo.sim.tem import load_rig_params

LAB_SENSOR_MM = 0.7
REFERENCES = ("pvc", "glass", "stainless_steel")
REFERENCE_SEEDS, EVALUATION_SEEDS = (8383, 8_300_000), (8484, 8_400_000)
KS, REPEATS, BLOCK = (3, 6, 12), 8, 12
EVALUATION_N = 300
ENOUGH_TOL = 0.02
WINDOWS = (mp.EARLY.window_s, mp.LATE.window_s)
POST_S = 1.35
TABLE = load_effusivity_table()
LN_B = np.log(np.array([b for b in TABLE.values()], float))
NAMES = list(TABLE)


def reference_draws(n: int, seeds: tuple[int, int]) -> list[dict[str, Any]]:
    """``n`` reference touches as a lab records them (module docstring)."""
    rng = np.random.default_rng(seeds[0])
    out = []
    for i in range(n):
        room = float(rng.uniform(20.0, 26.0))
        out.append(
            {
                "material": REFERENCES[i % len(REFERENCES)],
                "ambient_C": room,
                "T_object_C": room,
                "force_N": float(rng.uniform(3.0, 8.0)),
                "thickness_m": float(rng.uniform(10.0, 20.0)) * 1e-3,
                "t_on_s": PRE_S + float(rng.uniform(0.0, PERIOD_S)),
                "seed": seeds[1] + i,
            }
        )
    return out


def evaluation_draws(n: int, seeds: tuple[int, int]) -> list[dict[str, Any]]:
    """``n`` touches of the ten materials in the bench's in-box conditions (module docstring)."""
    rng = np.random.default_rng(seeds[0])
    sims = list(SIM_TO_TABLE)
    out = []
    for i in range(n):
        out.append(
            {
                "material": SIM_TO_TABLE[sims[i % len(sims)]],
                "sim": sims[i % len(sims)],
                "ambient_C": 25.0,
                "T_object_C": float(rng.uniform(15.0, 35.0)),
                "force_N": float(rng.uniform(2.0, 10.0)),
                "thickness_m": float(rng.uniform(1.0, 20.0)) * 1e-3,
                "t_on_s": PRE_S + float(rng.uniform(0.0, PERIOD_S)),
                "seed": seeds[1] + i,
            }
        )
    return out


def fitted(rig, t: dict[str, Any]) -> tuple[list, float]:
    """(the physics fit over each of WINDOWS or None, the probe's pre-contact mean, °C) of touch ``t``."""
    sim = t.get("sim") or next(s for s, name in SIM_TO_TABLE.items() if name == t["material"])
    T, Q, i0, _, _ = simulate_touch(
        rig,
        sim,
        t["thickness_m"],
        t["T_object_C"],
        t["force_N"],
        finger_natural_C(rig, t["ambient_C"]),
        seed=t["seed"],
        t_on_s=t["t_on_s"],
        identify=False,
        ambient_C=t["ambient_C"],
        post_s=POST_S,
    )
    n_pre = max(1, int(round(ProbeParams().pre_s / PERIOD_S)))
    T_probe = float(np.mean(T[i0 - n_pre : i0])) if i0 >= n_pre else math.nan
    return (ml.touch_fits(T, Q, i0, PERIOD_S, WINDOWS) if i0 >= 0 else [None, None]), T_probe


def score(evals: list, cals: tuple[mp.PhysicsCalibration, mp.PhysicsCalibration]) -> dict[str, float]:
    """Accuracy (abstentions wrong) and interval coverage of the early and the refined answer."""
    out: dict[str, float] = {}
    for w, (name, cal) in enumerate(zip(("early", "late"), cals)):
        right, covered, n_fit = 0, 0, 0
        for (fits, T_probe), t in evals:
            i, _, _ = mp.decide(fits[w], T_probe, LN_B, cal)
            right += i >= 0 and NAMES[i] == t["material"]
            e = cal.corrected(fits[w])
            if e is not None:
                n_fit += 1
                covered += abs(math.log(e.b) - math.log(TABLE[t["material"]])) <= 1.96 * cal.sigma_ci(
                    e.se_ln_b
                )
        out[f"accuracy_{name}"] = right / len(evals)
        out[f"ci95_coverage_{name}"] = covered / max(n_fit, 1)
    return out


def calibrate(refs: list, k: int) -> ml.LabCorrection:
    """The lab correction from the reference fits ``refs`` (the first ``k``)."""
    windows = []
    for w, base in enumerate((mp.EARLY, mp.LATE)):
        touches = [
            ml.LabTouch(math.log(f[w].b), f[w].se_ln_b, TABLE[t["material"]], t["material"])
            for (f, _), t in refs[:k]
            if f[w] is not None
        ]
        windows.append(ml.fit_window(touches, base.window_s, base))
    return ml.LabCorrection(early=windows[0], late=windows[1])


def probe_figures(rig, refs: list, evals: list) -> dict[str, Any]:
    """Before and after the lab correction from K reference touches, K in KS, on one probe."""
    fig: dict[str, Any] = {"before": score(evals, (mp.EARLY, mp.LATE)), "after": {}}
    for k in KS:
        runs = []
        for r in range(REPEATS):
            lab = calibrate(refs[r * BLOCK : (r + 1) * BLOCK], k)
            p = ml.lab_params(MaterialIdParams(calibration=None, envelope=None, envelope_late=None), lab)
            late = cast(mp.PhysicsCalibration, p.late)
            runs.append(score(evals, (p.early, late)) | {"late_model": cast(ml.LabWindow, lab.late).model})
        fig["after"][str(k)] = {
            key: {
                "median": float(np.median([x[key] for x in runs])),
                "worst": float(min(x[key] for x in runs)),
                "best": float(max(x[key] for x in runs)),
            }
            for key in runs[0]
            if key != "late_model"
        } | {"late_models": sorted({x["late_model"] for x in runs})}
    fig["lnb_rms_error_by_material"] = _rms_by_material(evals, calibrate(refs[:BLOCK], KS[-1]))
    return fig


def _rms_by_material(evals: list, lab: ml.LabCorrection) -> dict[str, dict[str, float]]:
    """RMS of ln b_fit − ln b_true over the refined fits, before and after the first block's K-max
    correction, per material."""
    out = {}
    late = cast(ml.LabWindow, lab.late)
    for m in NAMES:
        d = [
            (math.log(f[1].b), math.log(TABLE[m]))
            for (f, _), t in evals
            if t["material"] == m and f[1] is not None
        ]
        if d:
            x, y = np.array(d).T
            out[m] = {
                "before": float(np.sqrt(np.mean((x - y) ** 2))),
                "after": float(np.sqrt(np.mean((late.ln_b(x) - y) ** 2))),
            }
    return out


def touches_needed(after: dict[str, Any]) -> int | None:
    """The smallest K of KS whose median refined accuracy is within ENOUGH_TOL of the largest K's and whose
    refined interval covers 0.90–0.98 in every repeat (None: none)."""
    top = after[str(KS[-1])]["accuracy_late"]["median"]
    for k in KS:
        a = after[str(k)]
        cov = a["ci95_coverage_late"]
        if a["accuracy_late"]["median"] >= top - ENOUGH_TOL and cov["worst"] >= 0.90 and cov["best"] <= 0.98:
            return k
    return None


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.material_lab_calibrate", description=__doc__)
    ap.add_argument("--evaluation", type=int, default=EVALUATION_N, help="evaluation touches per probe")
    args = ap.parse_args(argv)
    p = MaterialIdParams()
    n_ref = REPEATS * BLOCK
    for seeds, n in ((REFERENCE_SEEDS, n_ref), (EVALUATION_SEEDS, args.evaluation)):
        refuse_overlap(n, seeds)
        me.check_seeds(p, n, seeds)
    t0 = time.perf_counter()
    base = load_rig_params()
    probes = {"shipped": base, "lab": base.with_(sensor_thickness_m=LAB_SENSOR_MM * 1e-3)}
    figs = {}
    for name, rig in probes.items():
        refs = [(fitted(rig, t), t) for t in reference_draws(n_ref, REFERENCE_SEEDS)]
        evals = [(fitted(rig, t), t) for t in evaluation_draws(args.evaluation, EVALUATION_SEEDS)]
        figs[name] = probe_figures(rig, refs, evals)
        print(name, figs[name]["before"], flush=True)
        for k, a in figs[name]["after"].items():
            print(f"  K={k}", {key: v["median"] for key, v in a.items() if isinstance(v, dict)}, flush=True)
    lab = figs["lab"]
    needed = touches_needed(lab["after"])
    k_report = str(needed if needed is not None else KS[-1])
    data = {
        "material_lab_accuracy_before": lab["before"]["accuracy_late"],
        "material_lab_accuracy_after": lab["after"][k_report]["accuracy_late"]["median"],
        "material_lab_touches_needed": needed,
        "material_lab_ci95_coverage_after": lab["after"][k_report]["ci95_coverage_late"]["median"],
        "material_lab_ci95_coverage_before": lab["before"]["ci95_coverage_late"],
        "material_lab_accuracy_early_before": lab["before"]["accuracy_early"],
        "material_lab_accuracy_early_after": lab["after"][k_report]["accuracy_early"]["median"],
        "material_lab_shipped_accuracy_before": figs["shipped"]["before"]["accuracy_late"],
        "material_lab_shipped_accuracy_after": figs["shipped"]["after"][k_report]["accuracy_late"]["median"],
        "material_lab_reported_at_touches": int(k_report),
        "material_lab_probe": {"sensor_thickness_mm": LAB_SENSOR_MM, "shipped_mm": 0.42},
        "material_lab_references": list(REFERENCES),
        "material_lab_seeds": {
            "reference": list(REFERENCE_SEEDS),
            "reference_touches": n_ref,
            "evaluation": list(EVALUATION_SEEDS),
            "evaluation_touches": args.evaluation,
        },
        "material_lab_repeats": REPEATS,
        "material_lab_by_probe": figs,
        "material_lab_wall_s": round(time.perf_counter() - t0, 1),
    }
    print(f"wrote {write_results('material_lab', data)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
