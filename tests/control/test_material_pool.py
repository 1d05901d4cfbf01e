"""The refined answer's pool of the two envelope classifiers (issue 23; material_calib.pooled,
its weights fitted by telethermo.offline.material_envelope_calibration.pool_weights, the slave's staged
classification in telethermo.control.material_stream)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from telethermo.control import material_id as mi
from telethermo.control.material_calib import (
    ENVELOPE_EARLY,
    ENVELOPE_LATE,
    calibration_vector,
    load_calibration,
    network_input,
    pooled,
    posterior,
    save_calibration,
)
from telethermo.control.material_stream import UNKNOWN_CODE, default_classes, default_envelope
from telethermo.offline.material_envelope_calibration import pool_weights
from telethermo.offline.material_touches import finger_natural_C, simulate_touch
from telethermo.sim.tem import load_rig_params

DT = 0.01
PARAMS = load_rig_params()
NAMES = {code: name for code, name, _ in default_classes()}
shipped = pytest.mark.skipif(
    default_envelope(ENVELOPE_EARLY) is None or default_envelope(ENVELOPE_LATE) is None,
    reason="no shipped envelope classifiers",
)


def test_the_pool_is_a_weighted_product_of_the_posteriors():
    pe = np.array([0.6, 0.3, 0.1])
    pl = np.array([0.2, 0.7, 0.1])
    assert pooled(pe, pl, (0.0, 1.0)) == pytest.approx(pl)
    assert pooled(pe, pl, (1.0, 0.0)) == pytest.approx(pe)
    both = pooled(pe, pl, (1.0, 1.0))
    assert both == pytest.approx(pe * pl / np.sum(pe * pl))
    half = pooled(pe, pl, (0.5, 0.5))  # the geometric mean: less sure than the product
    assert np.max(half) < np.max(both) and np.argmax(half) == np.argmax(both) == 1
    assert pooled(np.array([1.0, 0.0]), np.array([0.5, 0.5]), (1.0, 1.0)) == pytest.approx([1.0, 0.0])


def test_the_fitted_weights_trust_the_classifier_that_knows():
    """Touches whose true class the late classifier names at posterior 0.8 and the early one not at all
    (uniform noise): the likelihood gives the early one no weight and the late one about its calibration."""
    rng = np.random.default_rng(11)
    n, k = 2000, 5
    y = rng.integers(0, k, n)
    late = np.full((n, k), 0.05)
    late[np.arange(n), y] = 0.8
    wrong = rng.random(n) < 0.2  # 20 % of the late answers point at another class, as its 0.8 says
    other = (y + 1 + rng.integers(0, k - 1, n)) % k
    late[wrong] = 0.05
    late[wrong, other[wrong]] = 0.8
    early = rng.dirichlet(np.ones(k), n)
    w_early, w_late = pool_weights(early, late, y)
    assert w_early < 0.05 and w_late == pytest.approx(1.0, abs=0.1)


def test_a_malformed_pool_names_its_field(tmp_path):
    cal = load_calibration(ENVELOPE_LATE)
    path = save_calibration(replace(cal, pool=(0.5, 0.8)), tmp_path / "late.npz")
    assert load_calibration(path).pool == (0.5, 0.8)
    with np.load(path) as f:
        fields = {k: f[k] for k in f.files}
    bad = tmp_path / "bad.npz"
    for value in (np.array([-0.1, 1.0]), np.array([0.5, 0.5, 0.5])):
        np.savez(bad, **(fields | {"pool": value}))
        with pytest.raises(ValueError, match=r"bad\.npz: field 'pool': expected two weights >= 0"):
            load_calibration(bad)


@shipped
def test_the_refined_answer_pools_both_classifiers():
    """A probe resting at the 18 °C room's rest (outside the in-box classifier's box): by 1.5 s of contact the
    slave's refined answer is the pool of the early classifier over the first 0.3 s and the refined one over
    1.2 s, the same class and posterior as the batch computation, with the shipped weights."""
    late_cal = default_envelope(ENVELOPE_LATE)
    early_cal = default_envelope(ENVELOPE_EARLY)
    assert late_cal is not None and early_cal is not None and late_cal.pool is not None
    rest = finger_natural_C(PARAMS, 18.0)
    T, Q, i0, est, _ = simulate_touch(
        PARAMS, "ceramic", 0.003, 20.0, 1.0, rest, seed=943_001, t_on_s=0.2043, ambient_C=18.0, post_s=1.5
    )
    assert est is not None and est.by == "envelope" and est.stage == "late", est
    ps = []
    for cal, window_s in ((early_cal, 0.3), (late_cal, 1.2)):
        inp = mi.fit_input(T, Q, i0, DT, replace(mi.ProbeParams(), window_s=window_s))
        assert inp is not None
        x = network_input(cal, calibration_vector(cal, inp))
        assert x is not None
        ps.append(posterior(cal, x[None, :])[0])
    p = pooled(ps[0], ps[1], late_cal.pool)
    assert est.posterior == pytest.approx(float(np.max(p)), rel=1e-5)
    assert est.code == UNKNOWN_CODE or NAMES[est.code] == late_cal.classes[int(np.argmax(p))]
    assert float(np.max(p)) != pytest.approx(float(np.max(ps[1])), rel=1e-3)  # the pool changed it
