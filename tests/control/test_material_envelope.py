"""The envelope classifier (issue 23; telethermo.control.material_calib.envelope_vector, the slave's staged
classification outside the in-box classifier's box, telethermo/data/material_envelope_*.npz), and the refined
answer's pool of the early and the refined classifier (material_calib.pooled, its weights fitted by
telethermo.offline.material_envelope_calibration.pool_weights)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from telethermo.control import material_id as mi
from telethermo.control.material_calib import (
    ENVELOPE_EARLY,
    ENVELOPE_LATE,
    ENVELOPE_POOL,
    calibration_vector,
    classify_vector,
    envelope_vector,
    inputs,
    load_calibration,
    network_input,
    outside_references,
    pooled,
    posterior,
    save_calibration,
)
from telethermo.control.material_stream import (
    UNKNOWN_CODE,
    MaterialIdParams,
    MaterialState,
    default_classes,
    default_envelope,
    early_samples,
    fit_units,
    late_fit_units,
    late_samples,
    material_step,
)
from telethermo.control.material_train import TrainSettings
from telethermo.control.material_trust import (
    FLUX_COLLAPSE_MAX,
    FLUX_COLLAPSE_MAX_EARLY,
    FLUX_EARLY_LATER_S,
    flux_collapse,
)
from telethermo.offline.material_envelope_calibration import build, pool_weights
from telethermo.offline.material_touches import SIM_TO_TABLE, finger_natural_C, noise_of, simulate_touch
from telethermo.sim.tem import load_rig_params

DT = 0.01
PARAMS = load_rig_params()
NAMES = {code: name for code, name, _ in default_classes()}
shipped = pytest.mark.skipif(
    default_envelope(ENVELOPE_EARLY) is None or default_envelope(ENVELOPE_LATE) is None,
    reason="no shipped envelope classifiers",
)


def _inp(T: np.ndarray, Q: np.ndarray) -> mi.FitInput:
    inp = mi.fit_input(T, Q, 5, DT)
    assert inp is not None
    return inp


def test_a_hotter_object_has_the_shape_of_a_colder_one_with_the_flow_reversed():
    """Mirror a touch about the probe's pre-contact state (T0 − d, Q0 − q): the shape features are equal, the
    size (ln of the length) too, only the direction of the heat flow changes sign."""
    rng = np.random.default_rng(3)
    t = np.arange(35) * DT
    d = np.where(t >= 0.05, -4.0 * (1 - np.exp(-(t - 0.05) / 0.08)), 0.0) + rng.normal(0, 0.01, t.size)
    q = np.where(t >= 0.05, 0.9 * np.exp(-(t - 0.05) / 0.12), 0.0) + rng.normal(0, 0.002, t.size)
    cold = envelope_vector(_inp(33.6 + d, 0.05 + q), 3.0, 1)
    hot = envelope_vector(_inp(33.6 - d, 0.05 - q), 3.0, 1)
    m = 60
    assert cold[m + 1] == 1.0 and hot[m + 1] == -1.0
    assert np.allclose(cold[:m], hot[:m], atol=1e-9) and cold[m] == pytest.approx(hot[m], abs=1e-9)
    assert cold[m + 2] == pytest.approx(hot[m + 2], abs=0.05)  # the probe's pre-contact mean
    assert np.linalg.norm(cold[:m]) == pytest.approx(1.0, abs=1e-6)


def test_every_fourth_sample_of_the_late_window():
    T = 33.6 - np.linspace(0, 3, 125)
    Q = 0.05 + np.linspace(0, 1, 125)
    inp = mi.fit_input(T, Q, 5, DT, replace(mi.ProbeParams(), window_s=1.2))
    assert inp is not None
    assert envelope_vector(inp, 3.0, 4).shape == (2 * 30 + 4,)


def _tiny(tmp_path):
    rng = np.random.default_rng(1)
    V = rng.normal(size=(200, 64))
    y = rng.integers(0, len(SIM_TO_TABLE), 200)
    cal = build(V, y, 0.3, 1, TrainSettings(hidden=8, layers=1, epochs=1, warmup=1), "{}")
    return cal, save_calibration(cal, tmp_path / "env.npz"), V


def test_the_file_keeps_what_it_classifies(tmp_path):
    cal, path, V = _tiny(tmp_path)
    back = load_calibration(path)
    assert back.features == "envelope" and back.sub == 1 and back.n_win == 30
    assert classify_vector(back, V[0]) == classify_vector(cal, V[0])
    assert classify_vector(back, V[0][:-1]) is None  # another size: not classified


def test_a_malformed_envelope_file_names_its_field(tmp_path):
    _, path, _ = _tiny(tmp_path)
    with np.load(path) as f:
        fields = {k: f[k] for k in f.files}
    bad = tmp_path / "bad.npz"
    np.savez(bad, **(fields | {"features": np.array("spectrum")}))
    with pytest.raises(ValueError, match=r"bad\.npz: field 'features'"):
        load_calibration(bad)
    np.savez(bad, **(fields | {"sub": np.array(2)}))  # 2 × 15 + 4 values expected, 64 given
    with pytest.raises(ValueError, match=r"bad\.npz: field 'center'/'whiten': expected 34 values"):
        load_calibration(bad)


def test_the_references_range_is_kept_and_bounds_what_is_named(tmp_path):
    """build() records each input's range over its references; the file keeps it; a reference is inside, an
    input one reference standard deviation beyond the highest is outside at a smaller margin, not at a
    larger one."""
    cal, path, V = _tiny(tmp_path)
    X = inputs(cal.center, cal.whiten, cal.scale, V)
    assert np.allclose(cal.x_lo, X.min(axis=0)) and np.allclose(cal.x_hi, X.max(axis=0))
    back = load_calibration(path)
    assert np.array_equal(back.x_lo, cal.x_lo) and np.array_equal(back.x_hi, cal.x_hi)
    assert not any(outside_references(back, x, 0.0) for x in X)
    beyond = X[0].copy()
    beyond[7] = cal.x_hi[7] + 1.0
    assert outside_references(back, beyond, 0.5) and not outside_references(back, beyond, 1.5)
    assert not outside_references(replace(back, x_lo=None, x_hi=None), beyond, 0.0)  # no range: no check


def test_a_malformed_range_names_its_field(tmp_path):
    _, path, _ = _tiny(tmp_path)
    with np.load(path) as f:
        fields = {k: f[k] for k in f.files}
    bad = tmp_path / "bad.npz"
    np.savez(bad, **(fields | {"x_lo": fields["x_hi"] + 1.0}))
    with pytest.raises(ValueError, match=r"bad\.npz: field 'x_lo'/'x_hi': expected 64 ranges"):
        load_calibration(bad)
    np.savez(bad, **{k: v for k, v in fields.items() if k != "x_hi"})
    with pytest.raises(ValueError, match=r"bad\.npz: missing field 'x_hi'"):
        load_calibration(bad)


@shipped
def test_a_cup_of_tea_is_unknown_not_guessed():
    """An 85 °C object (the envelope ends at 50 °C), touched by the probe resting in an 18 °C room (outside
    the in-box classifier's box): the early answer is "unknown" because the physics fit puts the object
    beyond the temperatures the envelope classifier learnt, whatever the network would say. (The refined
    answer has no temperature check: material_trust.envelope_novelty says why.)"""
    rest = finger_natural_C(PARAMS, 18.0)
    _, _, i0, est, _ = simulate_touch(
        PARAMS, "glass", 0.01, 85.0, 5.0, rest, seed=941_003, t_on_s=0.2043, ambient_C=18.0, post_s=0.6
    )
    assert i0 >= 0 and est is not None and est.stage == "early" and est.by == "envelope", est
    assert est.code == UNKNOWN_CODE and est.abstained == "object_temperature", est
    assert est.T_object0_C > 60.0, est  # the fit sees a hot object: the reason is physics, not chance


@shipped
def test_the_staged_answer_is_the_batch_classification():
    """A probe resting at 18 °C room's rest (outside the in-box classifier's box): the slave's early answer is
    the envelope classifier's, the same class and posterior as the batch classification of the window."""
    rest = finger_natural_C(PARAMS, 18.0)
    T, Q, i0, est, _ = simulate_touch(
        PARAMS, "pvc", 0.02, 10.0, 5.0, rest, seed=940_001, t_on_s=0.2043, ambient_C=18.0, post_s=0.6
    )
    assert est.by == "envelope" and est.stage == "early", est
    env = default_envelope(ENVELOPE_EARLY)
    assert env is not None and env.n_win == 42  # its own window: 0.42 s (the physics fit's 0.3 s)
    inp = mi.fit_input(T, Q, i0, DT, replace(mi.ProbeParams(), window_s=env.n_win * DT))
    i, post = classify_vector(env, calibration_vector(env, inp))
    assert est.posterior == pytest.approx(post, rel=1e-6)
    assert est.code == UNKNOWN_CODE or NAMES[est.code] == env.classes[i]


@shipped
@pytest.mark.slow
def test_envelope_posterior_is_calibrated_on_held_out_touches():
    """120 envelope touches of seeds nothing was trained or chosen on (draw 9393, simulator 6100000 + i),
    objects ≥ 2 °C from the probe, the shipped probe: the refined answers' mean posterior lies within 0.1 of
    their accuracy (binomial SE about 0.045), and the answers at posterior ≥ 0.9 are right in ≥ 80 %."""
    rng = np.random.default_rng(9393)
    sims = list(SIM_TO_TABLE)
    post, right = [], []
    for i in range(120):
        ambient = float(rng.uniform(15.0, 32.0))
        rest = finger_natural_C(PARAMS, ambient)
        T_obj = float(rng.uniform(5.0, 50.0))
        force = math.exp(rng.uniform(math.log(0.5), math.log(20.0)))
        thick = math.exp(rng.uniform(math.log(0.3e-3), math.log(20e-3)))
        noise_x = float(rng.uniform(1.0, 3.0))
        if abs(T_obj - rest) < 2.0:
            continue
        _, _, _, est, _ = simulate_touch(
            PARAMS,
            sims[i % 10],
            thick,
            T_obj,
            force,
            rest,
            seed=6_100_000 + i,
            t_on_s=0.2043,
            noise=noise_of(noise_x),
            ambient_C=ambient,
            post_s=1.45,
        )
        if est is None or est.code in (0, UNKNOWN_CODE):
            continue
        post.append(est.posterior)
        right.append(NAMES[est.code] == SIM_TO_TABLE[sims[i % 10]])
    post_a, right_a = np.array(post), np.array(right, float)
    assert len(post_a) >= 60
    assert abs(post_a.mean() - right_a.mean()) <= 0.1, (post_a.mean(), right_a.mean(), len(post_a))
    conf = post_a >= 0.9
    assert conf.sum() >= 5 and right_a[conf].mean() >= 0.8, (conf.sum(), right_a[conf].mean())


@shipped
def test_a_foil_is_unknown_not_named_eps():
    """A 50 µm aluminium foil (the envelope's objects are ≥ 0.3 mm) at 10 °C, 5 N: it comes to the probe's
    temperature within a few hundredths of a second and then draws no heat, which the classifier reads as
    EPS. Its flux falls from its peak by far more than on any but 0.015 % of the reference touches
    (material_trust.flux_collapse), so the refined and the early answer are "unknown"; a 0.3 mm
    stainless-steel slab, the thinnest the envelope holds, touched alike, is judged and not turned away."""
    rest = finger_natural_C(PARAMS, 25.0)
    runs = {}
    for name, material, thick in (("foil", "aluminium", 50e-6), ("slab", "stainless_steel", 0.3e-3)):
        T, Q, i0, est, _ = simulate_touch(
            PARAMS, material, thick, 10.0, 5.0, rest, seed=942_001, t_on_s=0.2043, post_s=1.6
        )
        inp = mi.fit_input(T, Q, i0, DT, replace(mi.ProbeParams(), window_s=1.2))
        early = mi.fit_input(T, Q, i0, DT, replace(mi.ProbeParams(), window_s=0.3))
        assert inp is not None and early is not None and est is not None and est.stage == "late", est
        runs[name] = (flux_collapse(inp), est)
        early_ratio = flux_collapse(early, FLUX_EARLY_LATER_S)
        assert early_ratio is not None
        assert (early_ratio > FLUX_COLLAPSE_MAX_EARLY) == (name == "foil"), (name, early_ratio)
    ratio, est = runs["foil"]
    assert ratio is not None and ratio > 2 * FLUX_COLLAPSE_MAX, ratio
    assert est.code == UNKNOWN_CODE and est.abstained == "flux_collapse", est
    assert est.early_code == UNKNOWN_CODE, est  # the early answer's own check (0.20-0.28 s) saw it too
    ratio, est = runs["slab"]
    assert ratio is not None and ratio < 0.75 * FLUX_COLLAPSE_MAX, ratio
    assert est.abstained != "flux_collapse", est


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
    slave's refined answer is the pool of the pool's early classifier over the first 0.3 s (not the early
    answer's, over 0.42 s) and the refined one over 1.2 s, the same class and posterior as the batch
    computation, with the shipped weights."""
    late_cal = default_envelope(ENVELOPE_LATE)
    early_cal = default_envelope(ENVELOPE_POOL)
    assert late_cal is not None and early_cal is not None and late_cal.pool is not None
    assert early_cal.n_win == 30 and default_envelope(ENVELOPE_EARLY).n_win == 42
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


@shipped
def test_the_envelope_answers_come_when_the_schedule_says():
    """A 45 °C steel block (outside the in-box classifier's box: the envelope classifiers answer), the core's
    material_step run sample by sample: the early answer is out exactly fit_units cycles after its window
    (three physics units a cycle, one network layer a cycle), within 0.5 s of the contact, and the refined
    one late_fit_units cycles after its window."""
    rest = finger_natural_C(PARAMS, 25.0)
    T, Q, i0, est, _ = simulate_touch(
        PARAMS, "carbon_steel", 0.01, 45.0, 5.0, rest, seed=942_101, t_on_s=0.2043, post_s=1.45
    )
    p = MaterialIdParams()
    assert est is not None and est.by == "envelope" and est.stage == "late", est
    st, early_at, late_at = MaterialState(), None, None
    for k in range(T.size):
        st = material_step(p, st, T[k], Q[k], k >= i0, DT)
        if early_at is None and st.last.touch == 1:
            early_at = k
        if late_at is None and st.last.stage == "late":
            late_at = k
    assert early_at == i0 + early_samples(p, DT) - 1 + fit_units(p, DT), (early_at, i0)
    assert (early_at - i0 + 1) * DT <= 0.5
    assert late_at == i0 + late_samples(p, DT) - 1 + late_fit_units(p), (late_at, i0)
    assert (st.last.code, st.last.early_code) == (est.code, est.early_code)
