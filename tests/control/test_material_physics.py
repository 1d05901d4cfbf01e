"""The physics posterior (issue 23; telethermo.control.material_physics): abstains where the physics cannot
tell,
and a posterior calibrated on held-out envelope touches through the slave's core."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from telethermo.offline.material_touches import (
    SIM_TO_TABLE,
    envelope_draws,
    finger_natural_C,
    noise_of,
    other_tem,
    simulate_touch,
)
from telethermo.control import material_physics as mp
from telethermo.control.material_id import EffusivityEstimate
from telethermo.control.material_stream import UNKNOWN_CODE, default_classes
from telethermo.control.params import default_params
from telethermo.control.render_table import material_name
from telethermo.control.types import Role
from telethermo.sim.tem import load_rig_params

CLASSES = default_classes()
LN_B = np.log([b for _, _, b in CLASSES])
NAMES = {code: name for code, name, _ in CLASSES}


def _est(b: float, se: float, T_obj: float) -> EffusivityEstimate:
    return EffusivityEstimate(b=b, se_ln_b=se, T_object0_C=T_obj, R_contact_K_per_W=0.0, residual_C=0.0, n=10)


def test_a_material_with_no_neighbour_in_the_table_is_unknown():
    """b = 105 lies 1.3 in ln b from EPS (27.8) and from oak (392), the nearest entries: even a sharp fit
    (se 0.05) of a clearly colder object is "unknown" (posterior below the threshold), not a confident class;
    an effusivity on a table entry is named."""
    i, post, why = mp.decide(_est(105.0, 0.05, 20.0), 33.6, LN_B, mp.EARLY)
    assert i == -1 and why == "low_posterior" and post < mp.MIN_POSTERIOR
    i, post, why = mp.decide(_est(1620.0, 0.05, 20.0), 33.6, LN_B, mp.EARLY)
    assert CLASSES[i][1] == "glass" and post > 0.5 and why == ""


def test_physics_abstains_without_a_fit_or_a_temperature_difference():
    assert mp.decide(None, 33.6, LN_B, mp.EARLY)[2] == "no_fit"
    assert mp.decide(_est(1620.0, 0.05, 32.0), 33.6, LN_B, mp.EARLY)[2] == "weak_evidence"
    assert mp.decide(_est(1620.0, 0.05, 35.0), 33.6, LN_B, mp.EARLY)[2] == "weak_evidence"


def test_unknown_code_renders_as_unknown():
    assert material_name(UNKNOWN_CODE) == "unknown" and material_name(0) == "none"


def physics_only():
    """The slave core's parameters without the envelope classifiers: outside the box the physics posterior."""
    cp = default_params(Role.SLAVE, period_s=0.01)
    return replace(cp, material_id=replace(cp.material_id, envelope=None, envelope_late=None))


def test_posterior_is_calibrated_on_held_out_envelope_touches():
    """The slave without its envelope classifiers: 60 envelope touches of seeds no calibration or tuning used
    (draw 6262, simulator 1500000 + i), the objects >= 4 °C from the probe: the mean posterior of the physics
    answers lies within 0.12 of their accuracy, and the calibrated 95 % interval of every fit's b contains the
    truth in 80-100 %."""
    base = load_rig_params()
    rigs = {False: base, True: other_tem(base)}
    sims = list(SIM_TO_TABLE)
    core = physics_only()
    post, right, cov = [], [], []
    for t in envelope_draws(60, (6262, 1_500_000)):
        params = rigs[t["other_tem"]]
        T_probe = finger_natural_C(params, t["ambient_C"])
        if abs(T_probe - t["T_object_C"]) < 4.0:
            continue
        _, _, _, est, _ = simulate_touch(
            params,
            sims[t["class"]],
            t["thickness_m"],
            t["T_object_C"],
            t["force_N"],
            T_probe,
            seed=t["seed"],
            t_on_s=t["t_on_s"],
            noise=noise_of(t["noise_x"]),
            ambient_C=t["ambient_C"],
            post_s=0.5,
            core_params=core,
        )
        b_true = dict((n, b) for _, n, b in CLASSES)[SIM_TO_TABLE[sims[t["class"]]]]
        if math.isfinite(est.effusivity):  # every fit's interval, named or not
            cov.append(abs(math.log(est.effusivity / b_true)) <= 1.96 * est.se_ln_b)
        if est.by != "physics" or est.code == UNKNOWN_CODE:
            continue
        post.append(est.posterior)
        right.append(NAMES[est.code] == SIM_TO_TABLE[sims[t["class"]]])
    assert len(post) >= 20
    assert abs(np.mean(post) - np.mean(right)) <= 0.12, (np.mean(post), np.mean(right), len(post))
    assert 0.8 <= np.mean(cov) <= 1.0, np.mean(cov)
