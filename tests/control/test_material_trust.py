"""The slave names a material only inside what its calibration knows (issue 23;
telethermo.control.material_trust):
simulated touches through the slave's core, the shipped calibration."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from telethermo.control.material_stream import UNKNOWN_CODE, default_calibration, default_classes
from telethermo.control.material_trust import CalibrationBox
from telethermo.control.params import default_params
from telethermo.control.types import Role
from telethermo.offline.material_touches import SIM_TO_TABLE, draws, finger_natural_C, simulate_touch
from telethermo.sim.tem import load_rig_params

PARAMS = load_rig_params()
REST_C = finger_natural_C(PARAMS)
NAMES = {code: name for code, name, _ in default_classes()}
pytestmark = pytest.mark.skipif(default_calibration() is None, reason="no shipped calibration")


def test_the_box_rest_is_where_the_references_rested():
    assert abs(CalibrationBox().rest_C - REST_C) < 0.02


def test_an_object_hotter_than_the_probe_is_identified_from_the_reversed_flux():
    """Glass at 45 °C, 11 °C above the probe: heat flows into the probe (no reference touch of the network did
    that), so the physics posterior names it, from the fitted effusivity and object temperature; the refined
    answer (1.2 s of contact) too, with its posterior; the published interval contains glass's effusivity."""
    T, Q, i0, est, _ = simulate_touch(
        PARAMS, "glass", 0.02, 45.0, 8.0, REST_C, seed=930_011, t_on_s=0.2043, post_s=1.6
    )
    assert np.mean(Q[i0 : i0 + 30]) < np.mean(Q[i0 - 5 : i0]) - 0.05  # the flux reversed: into the probe
    assert est.touch == 1 and est.stage == "late" and est.abstained == "", est
    assert NAMES[est.early_code] == "glass" and est.early_posterior >= 0.5, est
    assert NAMES[est.code] == "glass" and est.posterior >= 0.5, est
    assert abs(est.T_object0_C - 45.0) < 1.0
    assert abs(math.log(est.effusivity / 1620.0)) <= 1.96 * est.se_ln_b


def test_a_probe_resting_elsewhere_is_named_by_the_physics_not_the_network():
    """Room at 18 °C: the probe rests 2 °C below the references' rest, outside the network's box: the answer
    is
    the physics posterior's (glass at 20 °C: named glass, not the network's class of an untrained rest)."""
    rest = finger_natural_C(PARAMS, 18.0)
    _, _, _, est, _ = simulate_touch(
        PARAMS, "glass", 0.02, 20.0, 8.0, rest, seed=930_002, t_on_s=0.2043, ambient_C=18.0
    )
    assert NAMES.get(est.code) == "glass" and 0.2 <= est.posterior < 1.0, est


def test_on_another_module_the_envelope_classifier_names_the_touch_not_the_network():
    """The same in-box touch (aluminium at 25 °C) with the box told that the probe is another module than the
    calibration's (what the node does after identify finds one): the in-box network does not answer, the
    envelope classifier (trained on a family of modules) does; with the shipped module the network names
    it."""
    core = default_params(Role.SLAVE)
    mid = core.material_id
    other = dataclasses.replace(
        core, material_id=dataclasses.replace(mid, box=dataclasses.replace(mid.box, probe_matches=False))
    )
    kw = dict(seed=930_021, t_on_s=0.2043)
    _, _, _, ship, _ = simulate_touch(PARAMS, "aluminium", 0.02, 25.0, 8.0, REST_C, core_params=core, **kw)
    _, _, _, swap, _ = simulate_touch(PARAMS, "aluminium", 0.02, 25.0, 8.0, REST_C, core_params=other, **kw)
    assert ship.by == "network", ship
    assert swap.by == "envelope" and swap.posterior < 1.0, swap


def test_an_object_at_the_probe_temperature_is_unknown():
    """The flux sensor's material at the probe's own temperature draws no heat: "unknown" (weak evidence)."""
    _, _, _, est, _ = simulate_touch(
        PARAMS, "flux_sensor", 0.01, REST_C + 0.3, 5.0, REST_C, seed=930_004, t_on_s=0.2043
    )
    assert est.code == UNKNOWN_CODE and est.abstained in ("weak_evidence", "no_fit", "low_posterior"), est


def test_in_the_box_the_posterior_is_calibrated_on_held_out_touches():
    """60 in-box touches of seeds no calibration or tuning used (draw 5151, simulator 910000 + i): the mean
    published posterior of the answers lies within 0.08 of their accuracy, those at ≥ 0.9 are right in ≥ 90 %,
    and at most 15 % are "unknown" (the near-probe band)."""
    post, right, unknown = [], [], 0
    sims = list(SIM_TO_TABLE)
    for d in draws(60, (5151, 910_000)):
        _, _, _, est, _ = simulate_touch(
            PARAMS,
            sims[d["class"]],
            d["thickness_m"],
            d["T_object_C"],
            d["force_N"],
            REST_C,
            seed=d["seed"],
            t_on_s=d["t_on_s"],
        )
        if est.code == UNKNOWN_CODE:
            unknown += 1
            continue
        post.append(est.posterior)
        right.append(NAMES[est.code] == SIM_TO_TABLE[sims[d["class"]]])
    post, right = np.array(post), np.array(right)
    assert unknown <= 9
    assert abs(post.mean() - right.mean()) <= 0.08, (post.mean(), right.mean())
    assert right[post >= 0.9].mean() >= 0.9 and not math.isnan(post.mean())
