"""What the early answer's "unknown" costs and what it buys (issue 23): the classes it withholds, scored.

``python -m bench.material_early_abstention [--n N] [--n-outside M] [--workers W]`` writes
``bench/results/material_early_abstention.json``.

The early answer (0.49 s after contact) is "unknown" on about a fifth of the envelope's touches outside the
near band, against one in twenty for the refined one, and the envelope benchmark counts every "unknown" as a
wrong answer. Most of those early abstentions are ``no_fit``: the physics fit over the first 0.3 s finds no
positive effusivity (with the probe's face barely moving, the heat drawn fixes only b·(T_face − T_o0), not
b and T_o0 apart), so there is no object temperature for the novelty and weak-evidence checks to read, and
the slave abstains whatever its classifier says. The classifier needs no fit (the refined answer names
such touches). Here every early abstention is scored with the class the envelope classifier would have
named (recomputed from the touch's window with the slave's own calibration, and checked against the named
answers), and the early figures are recomputed for rules that name some of them:

- ``shipped``: as the slave publishes;
- ``name_no_fit``: ``no_fit`` touches named when the posterior reaches material_physics.MIN_POSTERIOR;
- ``name_no_fit_drawing_heat``: the same, only where the flux's change in the first 0.15 s of contact
  reaches material_trust.FLUX_COLLAPSE_MIN_PEAK_W (material_trust.flux_peak_W: a touch that draws heat);
- ``name_every_abstention``: every abstention named (the most the lever can give).

Each is scored on the envelope's development touches (material_touches.DEVELOPMENT, seeds disjoint from the
evaluation's) and on touches beyond the envelope (material_touches.OUTSIDE_DEVELOPMENT): a rule that names
more inside must not name confidently outside what the classifier never learnt, so the second set's
confident precision sits beside the first's accuracy, with how many of its new confident wrong names the
refined answer (1.31 s) gives anyway.
"""

from __future__ import annotations

import argparse
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from typing import Any, cast

import numpy as np

from bench import material_id_bench as mb
from bench.common import write_results
from bench.material_id_envelope import after_identify, run_touch, simulate_drawn, split
from bench.material_id_scores import outside_figures
from telethermo.control.material_calib import Calibration, calibration_vector, classify_vector
from telethermo.control.material_id import fit_input, pre_samples
from telethermo.control.material_physics import MIN_POSTERIOR
from telethermo.control.material_stream import UNKNOWN_CODE, MaterialIdParams
from telethermo.control.material_trust import FLUX_COLLAPSE_MIN_PEAK_W, flux_peak_W
from telethermo.offline.material_touches import (
    DEVELOPMENT,
    OUTSIDE_DEVELOPMENT,
    envelope_draws,
    other_tem,
    outside_draws,
)
from telethermo.sim.tem import load_rig_params

#: simulated after contact for the early answer alone (published 0.49 s after contact), s
EARLY_POST_S = 0.6
RULES = ("shipped", "name_no_fit", "name_no_fit_drawing_heat", "name_every_abstention")
_CTX: dict[str, Any] = {}


def _context() -> dict[str, Any]:
    """The rigs, the slave cores after identify, the class names: built once per process."""
    if not _CTX:
        base = load_rig_params()
        rigs = {False: base, True: other_tem(base)}
        sims = list(mb.SIM_TO_TABLE)
        _CTX.update(
            rigs=rigs,
            sims=sims,
            names=[mb.SIM_TO_TABLE[m] for m in sims],
            cores={True: after_identify(rigs[True])},
            p=MaterialIdParams(),
        )
    return _CTX


def withheld(T: np.ndarray, Q: np.ndarray, i0: int, p: MaterialIdParams) -> tuple[int, float] | None:
    """(index in the early envelope classifier's classes, posterior) of the touch whose contact starts at
    sample ``i0``: its window as the slave's core cuts it (material_stream._first_input), None without one."""
    env = cast(Calibration, p.envelope)
    inp = fit_input(T, Q, i0, env.dt_s, p.probe)
    if inp is None:
        return None
    n_pre = pre_samples(p.probe, env.dt_s)
    own = replace(inp, T=T[i0 - n_pre : i0 + env.n_win], Q=Q[i0 - n_pre : i0 + env.n_win])
    return classify_vector(env, calibration_vector(env, own))


def score(t: dict) -> dict:
    """One touch: what the slave publishes (early and refined), the early answer's reason, and the class
    its envelope classifier withheld."""
    c = _context()
    row = run_touch(c["rigs"], t, c["sims"], c["names"], c["cores"])
    T, Q, i0, est, _ = simulate_drawn(c["rigs"], t, c["sims"], c["cores"], post_s=EARLY_POST_S)
    env = cast(Calibration, c["p"].envelope)
    T, Q = np.asarray(T, float), np.asarray(Q, float)
    inp = fit_input(T, Q, int(i0), env.dt_s, c["p"].probe) if i0 >= 0 else None
    w = withheld(T, Q, int(i0), c["p"]) if inp is not None else None
    named = env.classes[w[0]] if w is not None else None
    return {k: v for k, v in row.items() if k not in ("fit_positions_ms", "fit_step_ms")} | {
        "early_reason": est.abstained if est is not None and est.early_code == UNKNOWN_CODE else "",
        "early_by": est.by if est is not None else "",
        "withheld": c["names"].index(named) if named in c["names"] else -1,
        "withheld_posterior": w[1] if w is not None else 0.0,
        "flux_peak_W": flux_peak_W(inp) if inp is not None else 0.0,
    }


def under(rule: str, r: dict) -> dict:
    """Touch ``r`` with its early answer as ``rule`` would publish it."""
    why = r["early_reason"]
    name = why and r["withheld"] >= 0 and r["withheld_posterior"] >= MIN_POSTERIOR
    if rule == "name_no_fit":
        name = name and why == "no_fit"
    elif rule == "name_no_fit_drawing_heat":
        name = name and why == "no_fit" and r["flux_peak_W"] >= FLUX_COLLAPSE_MIN_PEAK_W
    elif rule != "name_every_abstention":
        name = False
    return r | {"answer_early": r["withheld"], "posterior_early": r["withheld_posterior"]} if name else r


def reasons(rows: list[dict]) -> dict[str, Any]:
    """Per early abstention reason: how many, and how often the withheld class is right, with its mean
    posterior (a calibrated classifier's two agree)."""
    out: dict[str, Any] = {}
    for why in sorted({r["early_reason"] for r in rows if r["early_reason"]}):
        rs = [r for r in rows if r["early_reason"] == why and r["withheld"] >= 0]
        out[why] = {
            "n": len(rs),
            "withheld_right": round(float(np.mean([r["withheld"] == r["class"] for r in rs])), 3)
            if rs
            else None,
            "withheld_posterior_mean": round(float(np.mean([r["withheld_posterior"] for r in rs])), 3)
            if rs
            else None,
        }
    return out


def rule_figures(inside: list[dict], outside: list[dict], rule: str) -> dict[str, Any]:
    """The early figures of ``rule`` inside the envelope (outside the near band, worst stratum) and beyond."""
    s = split([under(rule, r) for r in inside])
    far = {k: v["early"] for k, v in s.items() if not k.startswith("near")}
    o = outside_figures([under(rule, r) for r in outside])
    conf_wrong = [
        r
        for r in (under(rule, x) for x in outside)
        if r["answer_early"] >= 0 and r["posterior_early"] >= 0.9 and r["answer_early"] != r["class"]
    ]
    return {
        "early_accuracy": far["all_outside_near_band"]["accuracy"],
        "early_abstain_fraction": far["all_outside_near_band"]["abstain_fraction"],
        "early_ece": far["all_outside_near_band"]["ece"],
        "early_confident_precision": far["all_outside_near_band"]["confident_precision"],
        "early_accuracy_worst_stratum": min(v["accuracy"] for v in far.values()),
        "early_ece_worst_stratum": max(v["ece"] or 0.0 for v in far.values()),
        "early_confident_precision_worst_stratum": min(v["confident_precision"] or 1.0 for v in far.values()),
        "near_band_early_ece": s["near_probe_lt_2C"]["early"]["ece"],
        "outside_early": o["all"]["early"],
        "outside_early_by_kind": {k: v["early"] for k, v in o.items() if k != "all"},
        "outside_confident_wrong_early": len(conf_wrong),
        "outside_confident_wrong_early_also_late": sum(
            r["answer"] == r["answer_early"] and r["posterior"] >= 0.9 for r in conf_wrong
        ),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=2000, help="development touches inside the envelope")
    ap.add_argument("--n-outside", type=int, default=400, help="development touches beyond it")
    ap.add_argument("--workers", type=int, default=2)
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    with ProcessPoolExecutor(a.workers) as ex:
        inside = list(ex.map(score, envelope_draws(a.n, DEVELOPMENT), chunksize=20))
        outside = list(ex.map(score, outside_draws(a.n_outside, OUTSIDE_DEVELOPMENT), chunksize=20))
    # the recomputed class must be the one the slave names where it names one by its envelope classifier
    by_env = [r for r in inside + outside if r["early_by"] == "envelope" and r["answer_early"] >= 0]
    res = {
        "material_early_abstention_n_touches": len(inside),
        "material_early_abstention_n_outside": len(outside),
        "withheld_matches_named": round(
            float(np.mean([r["withheld"] == r["answer_early"] for r in by_env])), 4
        ),
        "withheld_matches_named_n": len(by_env),
        "reasons_inside": reasons([r for r in inside if abs(r["T_object_C"] - r["T_probe_C"]) >= 2.0]),
        "reasons_outside": reasons(outside),
        "rules": (rules := {rule: rule_figures(inside, outside, rule) for rule in RULES}),
        **{f"early_accuracy_{k}": v["early_accuracy"] for k, v in rules.items()},
        **{
            f"outside_confident_precision_early_{k}": v["outside_early"]["confident_precision"]
            for k, v in rules.items()
        },
        "seeds": {"inside": list(DEVELOPMENT), "outside": list(OUTSIDE_DEVELOPMENT)},
        "method": __doc__,
        "run_s": round(time.perf_counter() - t0, 1),
    }
    write_results("material_early_abstention", res)
    print(
        f"withheld class = named class on {res['withheld_matches_named']} of {len(by_env)} envelope answers"
    )
    for why, v in res["reasons_inside"].items():
        print(f"  inside, {why}: {v}")
    for rule, f in res["rules"].items():
        o = f["outside_early"]
        print(
            f"{rule:26s} early {f['early_accuracy']:.3f} (abstain {f['early_abstain_fraction']:.3f}, ECE "
            f"{f['early_ece']:.3f}, worst {f['early_ece_worst_stratum']:.3f}, confident "
            f"{f['early_confident_precision']:.3f}) | beyond: unknown {o['unknown_fraction']}, confident "
            f"{o['confident_n']} at {o['confident_precision']}, wrong {f['outside_confident_wrong_early']} "
            f"({f['outside_confident_wrong_early_also_late']} also late)"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
