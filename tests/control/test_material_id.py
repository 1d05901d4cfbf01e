"""Material identification on the slave (issue 15): physics of the estimator, the classifier, the core's
output."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from telethermo.sim.materials import material
from telethermo.sim.measurement import NoiseParams, butter2_lowpass as sim_butter2
from telethermo.sim.plant import Body, GridSettings
from telethermo.sim.rig import SimRig
from telethermo.sim.tem import load_rig_params
from telethermo.sim.touch import BodySpec, Schedule, Touch
from telethermo.control import material_id as mi
from telethermo.control.core import init_state, step
from telethermo.control.params import default_params
from telethermo.control.material_physics import EARLY
from telethermo.control.material_stream import (
    UNKNOWN_CODE,
    MaterialIdParams,
    MaterialState,
    default_classes,
    early_samples,
    fit_units,
    material_step,
)
from telethermo.control.rendering import load_render_table, relative_effusivity_from_contact
from telethermo.control.material_trust import CalibrationBox
from telethermo.control.types import PeerValues, Role
from telethermo.offline.material_touches import SIM_TO_TABLE
from telethermo.rig import RigSample

PARAMS = load_rig_params()
DT = 0.01
T_PROBE, T_OBJ = 33.0, 20.0


def touch(
    mat: str,
    *,
    noise: bool,
    seed: int = 0,
    force_N: float = 8.0,
    thickness_m: float = 0.02,
    T_probe_C: float = T_PROBE,
    params=PARAMS,
):
    """The slave (default controller, peer at T_PROBE) touches a slab at 0.205 s (half a period before the
    sample that flags it, the estimator's expectation of an unknown instant); 0.8 s of samples.
    Returns (samples, the core's last status, the contact face temperature 10 ms into the touch)."""
    grid = GridSettings(t_min_s=DT)
    body = Body(
        BodySpec("obj", material=mat, thickness_m=thickness_m, T0_C=T_OBJ),
        params.area_m2,
        25.0,
        params.h_air_W_m2K,
        grid,
    )
    schedule = Schedule([Touch(0.2 + 0.5 * DT, 10.0, "obj", force_N)])
    rig = SimRig(
        params,
        {"obj": body},
        schedule,
        ambient_C=25.0,
        period_s=DT,
        noise=NoiseParams(enabled=noise),
        seed=seed,
        grid=grid,
        start=T_probe_C,
    )
    cp = default_params(Role.SLAVE, period_s=DT)
    st = init_state(cp, None, rig.read())
    peer = PeerValues(estimate_C=T_probe_C, flux_W=0.0)
    samples, T_c = [], math.nan
    for _ in range(80):
        s = rig.read()
        samples.append(s)
        r = step(s, peer, cp, st)
        st = r.state
        rig.apply_current(r.current_A)
        rig.advance(DT)
        tr = rig.truth()
        if tr.touching and math.isnan(T_c):
            T_c = tr.T_contact_face_C
    return samples, r.status, T_c


def arrays(samples):
    T = np.array([s.T_sensor_C for s in samples])
    Q = np.array([s.Q_W for s in samples])
    i0 = next(i for i, s in enumerate(samples) if s.contact)
    return T, Q, i0


def test_table_effusivities_are_the_simulators():
    table = mi.load_effusivity_table()
    assert set(table) == set(SIM_TO_TABLE.values())
    for sim_name, name in SIM_TO_TABLE.items():
        assert table[name] == pytest.approx(material(sim_name).b, rel=1e-3), name


def test_classes_carry_the_render_tables_codes():
    codes = list(load_render_table())
    for code, name, _ in default_classes():
        assert codes[code - 1] == name


def test_filter_model_is_the_rigs_filter():
    for fc, fs in ((5.0, 100.0), (5.0, 20.0), (1.0, 1000.0)):
        assert mi.butter2_lowpass(fc, fs) == sim_butter2(fc, fs)


def test_half_integral_of_a_step():
    """I½[1](t) = 2·√(t/π) at the sample instants (sample 0 half a period into the step)."""
    M = mi.half_integral_matrix(30, DT, 0.5 * DT)
    t = (np.arange(30) + 0.5) * DT
    assert M @ np.ones(30) == pytest.approx(2.0 * np.sqrt(t / math.pi), rel=1e-12)


@pytest.mark.parametrize("mat,seed", [("glass", 1), ("glass", 2), ("ceramic", 1), ("ceramic", 2)])
def test_semi_infinite_body_matches_eq1_inverse_within_stated_confidence(mat, seed):
    """A 20 mm slab is semi-infinite for 0.3 s (√(a·t) ≤ 1.5 mm). Eq. 1 inverted with the contact face's
    temperature at the first instant (the flux sensor's own effusivity as the probe's) gives the object's
    effusivity; the estimator, from the noisy filtered samples only, agrees within 1.96 of its stated
    standard errors. Eq. 1 is the perfect-contact law: the contact's own resistance is removed here (the
    finite-contact case is the classifier's, tests/control/test_material_physics.py)."""
    samples, _, T_c = touch(mat, noise=True, seed=seed, params=PARAMS.with_(R_at_1N_m2K_W=1e-12))
    b_eq1 = material(PARAMS.sensor_material).b * relative_effusivity_from_contact(T_PROBE, T_OBJ, T_c)
    assert b_eq1 == pytest.approx(material(mat).b, rel=0.05)  # the simulator obeys eq. 1
    est = mi.estimate_effusivity(*arrays(samples), DT)
    assert est is not None and 0 < est.se_ln_b < 0.3
    assert abs(math.log(est.b / b_eq1)) <= 1.96 * est.se_ln_b, (est, b_eq1)
    lo, hi = est.interval()
    assert lo <= b_eq1 <= hi


@pytest.mark.parametrize("mat", ["eps", "glass", "copper"])
def test_core_classifies_far_apart_materials_on_clean_touches(mat):
    """EPS, glass and copper lie ≥ 1.2 apart in ln b: on clean touches the slave's core names each (the probe
    resting where the calibration's references did: elsewhere it says "unknown", test_material_trust.py)."""
    _, status, _ = touch(mat, noise=False, T_probe_C=CalibrationBox().rest_C)
    m = status.material
    assert m is not None and m.touch == 1
    names = {code: name for code, name, _ in default_classes()}
    assert names[m.code] == SIM_TO_TABLE[mat], m
    assert m.posterior > 0.5


def test_streaming_equals_batch():
    samples, status, _ = touch("glass", noise=True, seed=3)
    est = mi.estimate_effusivity(*arrays(samples), DT)
    assert status.material.effusivity == pytest.approx(est.b, rel=1e-12)
    assert status.material.se_ln_b == pytest.approx(EARLY.sigma_ci(est.se_ln_b), rel=1e-12)  # its interval's


def test_nan_input_gives_no_estimate():
    samples, _, _ = touch("glass", noise=True, seed=4)
    T, Q, i0 = arrays(samples)
    T[i0 + 5] = math.nan
    assert mi.estimate_effusivity(T, Q, i0, DT) is None
    assert mi.estimate_effusivity(T[: i0 + 10], Q[: i0 + 10], i0, DT) is None  # window incomplete
    assert mi.estimate_effusivity(T, Q, 0, DT) is None  # nothing before the touch
    p, st = MaterialIdParams(), MaterialState()
    for k in range(i0 + early_samples(p, DT) + 1):  # the window, then its first unit: nothing to fit
        st = material_step(p, st, T[k], Q[k], k >= i0, DT)
    assert st.last.touch == 1 and st.last.code in (0, UNKNOWN_CODE) and math.isnan(st.last.effusivity)


def test_core_survives_nan_samples_during_a_touch():
    cp = default_params(Role.SLAVE, period_s=DT)
    first = RigSample(t_s=0.0, T_sensor_C=T_PROBE, Q_W=0.0, current_A=0.0, contact=False, T_sink_C=25.0)
    st = init_state(cp, None, first)
    peer = PeerValues(estimate_C=T_PROBE, flux_W=0.0)
    for k in range(50):
        bad = 10 <= k < 14
        s = RigSample(
            t_s=k * DT,
            T_sensor_C=math.nan if bad else T_PROBE,
            Q_W=math.nan if bad else 0.5,
            current_A=0.0,
            contact=k >= 8,
            T_sink_C=25.0,
        )
        r = step(s, peer, cp, st)
        st = r.state
    assert r.status.material.code == 0 and math.isnan(r.status.material.effusivity)


def test_master_publishes_no_material():
    cp = default_params(Role.MASTER, period_s=DT)
    first = RigSample(t_s=0.0, T_sensor_C=T_PROBE, Q_W=0.0, current_A=0.0, contact=False, T_sink_C=25.0)
    r = step(first, PeerValues(estimate_C=T_PROBE, flux_W=0.0), cp, init_state(cp, None, first))
    assert r.status.material is None


def test_fit_is_spread_over_cycles_and_equals_the_batch_fit():
    """No cycle carries the whole fit: the window completes, then one unit of work per cycle (window and
    energy form, flux form, each noise realisation, classification: one calibrated material per cycle); the
    result appears exactly fit_units cycles later and equals the batch estimate."""
    samples, _, _ = touch("ceramic", noise=True, seed=5)
    T, Q, i0 = arrays(samples)
    p = MaterialIdParams()
    n_win = early_samples(p, DT)  # the early envelope classifier's window (0.42 s), the fit's 0.3 s inside it
    units = fit_units(p, DT)
    st = MaterialState()
    seen = []
    for k in range(i0 + n_win + units + 2):
        st = material_step(p, st, T[k], Q[k], k >= i0, DT)
        seen.append((st.job is not None, st.last.touch))
    k_full = i0 + n_win - 1  # the cycle that completes the window
    assert all(job for job, _ in seen[k_full : k_full + units])
    assert [touch for _, touch in seen[: k_full + units]] == [0] * (k_full + units)
    assert seen[k_full + units] == (False, 1)
    est = mi.estimate_effusivity(T, Q, i0, DT)
    assert st.last.effusivity == pytest.approx(est.b, rel=1e-12)
    assert st.last.se_ln_b == pytest.approx(EARLY.sigma_ci(est.se_ln_b), rel=1e-12)


def test_the_early_answer_waits_for_the_longer_of_its_two_windows():
    """The physics fit's window is 0.3 s, the shipped early envelope classifier's 0.42 s: the early job starts
    when the longer is collected (the answer 0.42 s + fit_units cycles after the touch: 0.49 s at 100 Hz);
    without an envelope classifier, or with one measured at another period, the fit's own window."""
    p = MaterialIdParams()
    assert int(round(p.probe.window_s / DT)) == 30 and p.envelope is not None and p.envelope.n_win == 42
    assert early_samples(p, DT) == 42 and (early_samples(p, DT) + fit_units(p, DT)) * DT <= 0.5
    assert early_samples(replace(p, envelope=None), DT) == 30
    assert early_samples(p, 2 * DT) == int(round(p.probe.window_s / (2 * DT)))


def test_a_new_touch_during_a_fit_does_not_lose_the_held_result():
    """A release and a new touch while the fit runs: the fit finishes (the release clears nothing)."""
    samples, _, _ = touch("glass", noise=True, seed=6)
    T, Q, i0 = arrays(samples)
    p = MaterialIdParams()
    n_win = early_samples(p, DT)  # the early envelope classifier's window (0.42 s), the fit's 0.3 s inside it
    st = MaterialState()
    for k in range(i0 + n_win + 2):
        st = material_step(p, st, T[k], Q[k], k >= i0, DT)
    for k in range(20):  # released: the fit carries on
        st = material_step(p, st, T[-1], Q[-1], False, DT)
    assert st.job is None and st.last.touch == 1 and st.last.code != 0
