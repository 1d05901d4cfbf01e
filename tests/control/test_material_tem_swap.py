"""Issue 23's proof: a swapped probe TEM after ``identify`` keeps the identification's accuracy within 0.03 of
the shipped one's, on a fixed test set. Simulated touches through the slave's core (the shipped calibration,
the physics posterior and the abstain rule as the slave runs them)."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from telethermo.control.material_stream import MaterialEstimate, default_calibration, default_classes
from telethermo.control.types import Role
from telethermo.offline import material_touches as mt
from telethermo.offline.envelope import RANGES, identified_params
from telethermo.sim.tem import load_rig_params

#: the fixed test set: (draw seed, first simulator seed) of in-box touches (mt.draws), and its size
TEST_SET, N = (2727, 1_500_000), 400
#: the other module, factors on the shipped TEM's values (each inside the envelope's s_* ranges)
SWAP = {"seebeck_x": 1.8, "R_x": 2.2, "plate_C_x": 1.5}
#: the identification's seed (telethermo identify's PRBS seed on the swapped probe's free pad)
IDENTIFY_SEED = 7
TOLERANCE = 0.03
#: after contact, s: the refined answer (1.2 s window, its fit, both networks) is out by 1.39 s
POST_S = 1.45
CODES = {name: code for code, name, _ in default_classes()}
pytestmark = pytest.mark.slow  # 800 simulated touches and one identification: about a minute here


def swapped_rig():
    """The shipped rig with the other module (Seebeck, resistance, plate capacity scaled by :data:`SWAP`)."""
    base = load_rig_params()
    tem = dataclasses.replace(
        base.tem,
        alpha_V_K=base.tem.alpha_V_K * SWAP["seebeck_x"],
        R_ohm=base.tem.R_ohm * SWAP["R_x"],
        plate_C_J_K=base.tem.plate_C_J_K * SWAP["plate_C_x"],
    )
    return base.with_(tem=tem)


def _right(est: MaterialEstimate | None, truth: str) -> tuple[bool, bool]:
    """(the first answer is right, the refined one is right); an abstention ("unknown") or none is wrong."""
    if est is None or est.touch != 1:
        return False, False
    return est.early_code == CODES[truth], est.code == CODES[truth]


def test_the_test_set_is_disjoint_from_every_calibration_and_evaluation():
    sets = [
        (*mt.EVALUATION, mt.EVALUATION_N),
        (*mt.HELDOUT, mt.HELDOUT_N),
        (*mt.ENVELOPE, mt.ENVELOPE_N),
        (*mt.DEVELOPMENT, mt.DEVELOPMENT_N),
        (*mt.PHYSICS_CALIBRATION, mt.PHYSICS_CALIBRATION_N),
        # development sets docs/material_id.md names (their scripts not kept): box, rounds 2-3, round 1
        (4344, 710_000, 1000),
        (4242, 800_000, 1000),
        (2015, 200_000, 600),
    ]
    cal = default_calibration()
    if cal is not None:  # the shipped network's references (and dense ones)
        info = json.loads(cal.info)
        sets.append((int(info["draw_seed"]), int(info["sim_seed_first"]), int(info["reference_touches"])))
        d = info.get("dense") or {}
        if d:
            sets.append((int(d["draw_seed"]), int(d["sim_seed_first"]), int(d["touches"])))
    for draw, first, n in sets:
        assert TEST_SET[0] != draw and not (TEST_SET[1] < first + n and TEST_SET[1] + N > first), (
            draw,
            first,
        )
    for k, x in SWAP.items():
        lo, hi, _ = RANGES[f"s_{k}"]
        assert lo <= x <= hi and x != 1.0, k


@pytest.mark.xfail(
    strict=True,
    reason=(
        "measured (400 paired in-box touches, seeds 2727/1500000, module Seebeck x1.8, R x2.2, plate C x1.5, "
        "identified with seed 7: rho 0.748): shipped 0.890/0.915 (first/refined), swapped after identify "
        "0.840/0.898, difference 0.05/0.017 (paired SE 0.013/0.010): the refined answer (the two envelope "
        "classifiers pooled) is within 0.03, the first is not. The in-box network learnt the shipped "
        "module's closed loop, so on another module the node's box says 'another_tem' and the envelope "
        "classifier answers (trained on the shipped probe and a family of twelve other modules after "
        "identify; "
        "before it, the physics posterior: 0.500/0.518); what is left is the in-box network's edge on its "
        "own module"
    ),
)
def test_a_swapped_tem_after_identify_keeps_the_accuracy_within_0_03():
    """A fixed set of N = 400 in-box touches (mt.draws with seeds :data:`TEST_SET`: the ten materials in turn,
    2–10 N, 15–35 °C, 1–20 mm, the rig's noise, the probe resting at the finger's natural temperature), each
    simulated twice with the same seeds: with the shipped probe TEM and the slave's defaults, and with another
    module (:data:`SWAP`) after ``telethermo identify`` on its free pad (the offline identification the
    envelope bench uses, telethermo.offline.envelope.identified_params: the identified model's gains). The
    accuracy (abstentions wrong) of the first answer and of the refined one may differ by at most 0.03.

    Statistics: the two runs are paired (same touch, same noise), so the difference's standard error is
    √(discordant fraction / N): 0.011 with 5 % discordant touches, and each accuracy's own binomial SE is
    √(0.83·0.17/400) = 0.019; 0.03 is then about 2.7 SE of the difference. Measured today the difference is
    0.05/0.017 with a paired SE of 0.013/0.010 (the xfail reason; 0.07 for the first answer before its
    envelope classifier's window became 0.34 s, 0.04 before 0.42 s: the shipped module's first answer gained
    more than the swapped one's, 0.882 -> 0.890 against 0.842 -> 0.840)."""
    ship = load_rig_params()
    other = swapped_rig()
    cp, fit = identified_params(Role.SLAVE, other, mt.AMBIENT_C, mt.PERIOD_S, IDENTIFY_SEED)
    assert not fit.get("identify_refused", False), fit
    sims = list(mt.SIM_TO_TABLE)
    right: dict[str, list[tuple[bool, bool]]] = {"shipped": [], "swapped": []}
    for t in mt.draws(N, TEST_SET):
        mat = sims[t["class"]]
        for key, params, core in (("shipped", ship, None), ("swapped", other, cp)):
            rest_C = mt.finger_natural_C(params)
            _, _, _, est, _ = mt.simulate_touch(
                params,
                mat,
                t["thickness_m"],
                t["T_object_C"],
                t["force_N"],
                rest_C,
                seed=t["seed"],
                t_on_s=t["t_on_s"],
                post_s=POST_S,
                core_params=core,
            )
            right[key].append(_right(est, mt.SIM_TO_TABLE[mat]))
    a, b = np.array(right["shipped"], float), np.array(right["swapped"], float)
    se = np.std(a - b, axis=0, ddof=1) / np.sqrt(N)
    figures = (
        f"accuracy first/refined: shipped {a.mean(0).round(3)}, swapped {b.mean(0).round(3)}, "
        f"paired SE {se.round(3)}, rho {fit.get('rho')}"
    )
    assert np.all(np.abs(a.mean(0) - b.mean(0)) <= TOLERANCE), figures


def test_the_node_tells_its_material_box_when_identify_finds_another_module():
    """After identify the node knows whether its probe is the calibration's module: the shipped rig
    re-identified stays inside the box (the network names its touches), the other module is outside it
    ("another_tem": the physics posterior answers)."""
    cp_ship, fit_ship = identified_params(
        Role.SLAVE, load_rig_params(), mt.AMBIENT_C, mt.PERIOD_S, IDENTIFY_SEED
    )
    cp_other, fit_other = identified_params(
        Role.SLAVE, swapped_rig(), mt.AMBIENT_C, mt.PERIOD_S, IDENTIFY_SEED
    )
    assert abs(fit_ship["plant_gain_ratio"] - 1.0) < 0.05, fit_ship["plant_gain_ratio"]
    assert cp_ship.material_id.box.probe_matches
    assert fit_other["plant_gain_ratio"] > 1.15 and not cp_other.material_id.box.probe_matches
