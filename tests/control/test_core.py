"""The step function's contract, without a plant: purity, peer handling, modes, bumpless switching."""

import dataclasses
import math

import pytest
from hypothesis import given, settings, strategies as st

from telethermo.control.core import CoreParams, RenderPhase, RenderSettings, init_state, step
from telethermo.control.estimators import Estimator
from telethermo.control.params import default_params
from telethermo.control.safety import EMCY_CODES, SafetyState, Trip
from telethermo.control.types import Mode, PeerValues, Role
from telethermo.rig import RigSample


def S(t=0.0, T=33.0, Q=0.0, I=0.0, contact=False, sink=26.0):
    return RigSample(t, T, Q, I, contact, sink)


P = CoreParams(role=Role.MASTER, kp_A_per_C=0.5, ki_A_per_C_s=2.0, kQ_A_per_W=0.3)


def test_params_validation_names_the_field():
    with pytest.raises(ValueError, match=r"CoreParams.period_s: expected > 0.0"):
        CoreParams(role=Role.MASTER, period_s=0.0)
    with pytest.raises(ValueError, match="CoreParams.kp_A_per_C: expected a finite number"):
        CoreParams(role=Role.SLAVE, kp_A_per_C=math.nan)
    with pytest.raises(ValueError, match="CoreParams.render: RENDER mode needs RenderSettings"):
        CoreParams(role=Role.MASTER, mode=Mode.RENDER)
    with pytest.raises(ValueError, match="RENDER runs on the master only"):
        CoreParams(role=Role.SLAVE, mode=Mode.RENDER, render=RenderSettings(0.74, 25.0))
    with pytest.raises(ValueError, match="needs a TEM model"):
        init_state(CoreParams(role=Role.MASTER, estimator=Estimator.MODEL), None, S())


def test_step_is_pure():
    st0 = init_state(P, None, S())
    a = step(S(T=32.0, Q=0.2), PeerValues(29.0, 0.4), P, st0)
    b = step(S(T=32.0, Q=0.2), PeerValues(29.0, 0.4), P, st0)
    assert a == b
    assert st0 == init_state(P, None, S())


def test_flux_estimate_and_feedforward_sign():
    st0 = init_state(P, None, S())
    r = step(S(T=30.0, Q=0.5), PeerValues(30.0, 0.8), P, st0)
    assert r.status.estimate_C == pytest.approx(30.0 - 0.5 * P.R_sensor_K_per_W / 2)
    assert r.out.estimate_C == r.status.estimate_C and r.out.flux_W == 0.5
    # the peer's contact draws 0.8 W out of its pad: this pad must absorb heat -> cooling feed-forward
    assert r.status.pi.ff_A == pytest.approx(-0.3 * 0.8)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, 1e9, -1e9, 500.0])
def test_bad_peer_never_reaches_the_command(bad):
    st0 = init_state(P, None, S())
    good = step(S(), PeerValues(33.0, 0.0), P, st0)
    for pv in (PeerValues(bad, 0.0), PeerValues(33.0, bad)):
        r = step(S(t=0.01), pv, P, good.state)
        assert Trip.PEER_INVALID in r.status.trips
        assert r.status.new_emcy_codes == (EMCY_CODES[Trip.PEER_INVALID],)
        assert math.isfinite(r.current_A) and abs(r.current_A) <= P.safety.I_limit_A
        assert r.status.safety_state is SafetyState.RAMP_TO_NEUTRAL
        assert r.status.pi.ff_A == 0.0
        assert math.isfinite(r.status.setpoint_C) and 15.0 <= r.status.setpoint_C <= 43.0


def test_peer_lost_ramps_to_neutral_then_cuts():
    st = init_state(P, None, S(T=28.0))
    r = step(S(T=28.0), PeerValues(28.0, 0.0), P, st)
    sps = []
    T = 28.0
    for k in range(1, 200):  # a pad that follows the setpoint a cycle late (the ramp waits for a lagging one)
        r = step(S(t=0.01 * k, T=T), PeerValues(28.0, 0.0, alive=False), P, r.state)
        sps.append(r.status.setpoint_C)
        T = r.status.setpoint_C
        if r.status.safety_state is SafetyState.CUT:
            break
    assert r.current_A == 0.0 and abs(sps[-1] - 32.0) <= 0.3
    assert all(b - a <= 0.05 + 1e-9 for a, b in zip(sps, sps[1:]))
    assert r.status.error_register == 0x11


def test_peer_lost_with_a_pad_that_does_not_follow_cuts_at_the_neutral_timeout():
    st = init_state(P, None, S(T=28.0))
    r = step(S(T=28.0), PeerValues(28.0, 0.0), P, st)
    n = int(P.safety.neutral_timeout_s / P.period_s)
    for k in range(1, n + 2):
        r = step(S(t=0.01 * k, T=28.0), PeerValues(28.0, 0.0, alive=False), P, r.state)
        if k < n - 1:
            assert r.status.setpoint_C <= 28.0 + P.safety.trip_lead_C + 1e-9 and r.current_A > 0.0
    assert r.status.safety_state is SafetyState.CUT and r.current_A == 0.0


def test_no_peer_in_telepresence_is_peer_lost():
    r = step(S(), None, P, init_state(P, None, S()))
    assert Trip.PEER_LOST in r.status.trips


def test_nan_sensor_cuts_current_immediately():
    st0 = init_state(P, None, S())
    r = step(S(), PeerValues(20.0, 2.0), P, st0)
    r = step(S(t=0.01, T=math.nan), PeerValues(20.0, 2.0), P, r.state)
    assert r.current_A == 0.0 and Trip.SENSOR_INVALID in r.status.trips
    assert r.status.safety_state is SafetyState.CUT


def test_mode_switch_is_bumpless():
    st0 = init_state(P, None, S())
    r = None
    s = st0
    for k in range(100):
        r = step(S(t=0.01 * k, T=31.0), PeerValues(30.0, 0.3), P, s)
        s = r.state
    u_before = r.current_A
    assert abs(u_before) > 0.05
    P2 = dataclasses.replace(P, mode=Mode.RENDER, render=RenderSettings(beta_object=0.74, T_object0_C=25.0))
    r2 = step(S(t=1.0, T=31.0), None, P2, s)
    # the first step in the new mode starts from the previous current (only one integration step away)
    assert abs(r2.current_A - u_before) <= P.ki_A_per_C_s * abs(r2.status.setpoint_C - 31.0) * 0.01 + 1e-9
    # gain change: integral kept in A, output continuous up to the proportional change
    P3 = dataclasses.replace(P, ki_A_per_C_s=10.0)
    r3 = step(S(t=1.0, T=31.0), PeerValues(30.0, 0.3), P3, s)
    assert abs(r3.current_A - u_before) < 0.02


def test_idle_ramps_current_to_zero():
    s = init_state(P, None, S())
    r = step(S(T=31.0), PeerValues(25.0, 0.0), P, s)
    for k in range(50):
        r = step(S(t=0.01 * k, T=31.0), PeerValues(25.0, 0.0), P, r.state)
    u0 = r.current_A
    assert u0 < -0.5
    P2 = dataclasses.replace(P, mode=Mode.IDLE, idle_ramp_A_per_s=4.0)
    us = []
    for k in range(100):
        r = step(S(t=1 + 0.01 * k, T=31.0), None, P2, r.state)
        us.append(r.current_A)
    assert us[0] == pytest.approx(u0 + 0.04)
    assert us[-1] == 0.0 and all(b >= a for a, b in zip(us, us[1:]))


def test_render_preset_then_contact_switch():
    rs = RenderSettings(beta_object=5.6, T_object0_C=25.0, beta_pad=2.23, T_finger0_C=33.0)
    Pm = CoreParams(role=Role.MASTER, mode=Mode.RENDER, render=rs, kp_A_per_C=0.7, ki_A_per_C_s=1.0)
    s = init_state(Pm, None, S(T=rs.T_pad0_C + 0.5))
    r = step(S(T=rs.T_pad0_C + 0.5), None, Pm, s)
    for k in range(1, 30):
        r = step(S(t=0.01 * k, T=rs.T_pad0_C + 0.5), None, Pm, r.state)
    assert r.status.render_phase is RenderPhase.PRESET and r.status.requested_setpoint_C == pytest.approx(
        rs.T_pad0_C
    )
    u_pre = r.current_A
    assert u_pre < 0  # pad above its pre-set: cooling
    # the finger touches: ~1.5 W flows into the pad (measured), the filtered sensor still near T_pad0
    r = step(S(t=0.3, T=rs.T_pad0_C + 0.6, Q=-1.5), None, Pm, r.state)
    assert r.status.contact and r.status.render_phase is RenderPhase.CONTACT
    # yamamoto's command switch: T_contact at once (it lies between T_pad0 and T_finger0), no ramp
    assert r.status.setpoint_C == pytest.approx(rs.T_contact_C)
    assert rs.T_pad0_C < rs.T_contact_C < rs.T_finger0_C
    # the current is held while the filtered measurements settle (settle_s = 0.1 s)
    held = [r.current_A]
    for k in range(1, 15):
        r = step(S(t=0.3 + 0.01 * k, T=rs.T_contact_C - 0.5, Q=0.0), None, Pm, r.state)
        held.append(r.current_A)
    assert held[:10] == [u_pre] * 10
    # then the PI resumes bumplessly towards T_contact (surface 0.5 °C below: heating grows)
    assert held[10] == pytest.approx(u_pre, abs=0.02) and held[-1] > held[10]


@settings(max_examples=300, deadline=None)
@given(
    T=st.floats(allow_nan=True, allow_infinity=True),
    Q=st.floats(allow_nan=True, allow_infinity=True),
    sink=st.floats(allow_nan=True, allow_infinity=True),
    pe=st.floats(allow_nan=True, allow_infinity=True),
    pq=st.floats(allow_nan=True, allow_infinity=True),
    alive=st.booleans(),
    kp=st.floats(0, 100),
    ki=st.floats(0, 1000),
    kq=st.floats(-100, 100),
    mode=st.sampled_from([Mode.TELEPRESENCE, Mode.IDLE, Mode.IDENTIFY]),
)
def test_any_input_gives_a_bounded_finite_current(T, Q, sink, pe, pq, alive, kp, ki, kq, mode):
    p = CoreParams(role=Role.SLAVE, mode=mode, kp_A_per_C=kp, ki_A_per_C_s=ki, kQ_A_per_W=kq)
    s = init_state(p, None, S())
    r = step(S(), PeerValues(33.0, 0.0), p, s)
    r = step(S(t=0.01, T=T, Q=Q, sink=sink), PeerValues(pe, pq, alive=alive), p, r.state)
    assert math.isfinite(r.current_A) and abs(r.current_A) <= p.safety.I_limit_A
    assert 15.0 <= r.status.setpoint_C <= 43.0
    surf = [T, T - Q * p.R_sensor_K_per_W / 2]
    if not all(math.isfinite(x) for x in surf):
        assert r.current_A == 0.0
    elif max(surf) >= 42.5:
        assert r.current_A <= 0.0
    elif min(surf) <= 15.5:
        assert r.current_A >= 0.0


def test_identify_mode_runs_the_plan_then_holds_zero():
    from telethermo.ident.plan import IdentifyPlan

    plan = IdentifyPlan(
        seed=3,
        rest_samples=20,
        train_samples=150,
        validation_samples=80,
        amplitude_A=(0.2, 0.6),
        hold_samples=5,
    )
    p = CoreParams(role=Role.MASTER, mode=Mode.IDENTIFY, identify=plan)
    r = step(S(), None, p, init_state(p, None, S()))
    us = [r.current_A]
    for k in range(1, plan.total + 30):
        r = step(S(t=0.01 * k), None, p, r.state)
        us.append(r.current_A)
    # sample j of the mode carries the plan's current j (the pad far from the envelope: no guard)
    assert us[: plan.total] == list(plan.currents())
    assert all(u == 0.0 for u in us[:20]) and set(us[plan.total :]) == {0.0}
    assert r.state.ident_k == plan.total + 30 and r.state.ident_guard == 0
    # within the plan's margin of the top clamp the guard flips heating into cooling, and counts it
    p2 = CoreParams(
        role=Role.MASTER, mode=Mode.IDENTIFY, identify=IdentifyPlan(rest_samples=0, amplitude_A=(0.5, 0.5))
    )
    r = step(S(T=42.5), None, p2, init_state(p2, None, S(T=42.5)))
    r2 = step(S(t=0.01, T=42.5), None, p2, r.state)
    assert r.current_A <= 0.0 and r2.current_A <= 0.0 and r2.state.ident_guard >= 1
    # leaving the mode and coming back starts the experiment again from sample 0
    pi = CoreParams(role=Role.MASTER, mode=Mode.IDLE)
    r3 = step(S(t=0.02), None, pi, r2.state)
    assert r3.state.ident_k == 0
    r4 = step(S(t=0.03), None, p, r3.state)
    assert r4.state.ident_k == 1


def test_clear_faults_releases_a_gone_trip_and_restarts_bumpless():
    s = init_state(P, None, S())
    r = step(S(), PeerValues(33.0, 0.0), P, s)
    r = step(S(t=0.01, sink=60.0), PeerValues(33.0, 0.0), P, r.state)
    assert Trip.HEAT_SINK in r.status.trips and r.current_A == 0.0
    from telethermo.control.core import clear_faults

    still = clear_faults(S(t=0.02, sink=60.0), PeerValues(33.0, 0.0), P, r.state)
    assert Trip.HEAT_SINK in still.env.trips and still.env.cut
    ok = clear_faults(S(t=0.02, sink=30.0), PeerValues(33.0, 0.0), P, r.state)
    assert not ok.env.trips and not ok.env.cut
    r2 = step(S(t=0.03, sink=30.0), PeerValues(33.0, 0.0), P, ok)
    assert r2.status.safety_state in (SafetyState.OK, SafetyState.LIMITING) and abs(r2.current_A) < 0.05


def test_slave_echoes_the_finger_estimate_while_free_if_asked():
    ps = CoreParams(role=Role.SLAVE, echo_peer_when_free=True)
    s = init_state(ps, None, S(T=30.0))
    r = step(S(T=30.0), PeerValues(33.5, 0.0), ps, s)
    assert not r.status.contact and r.out.estimate_C == 33.5 and r.status.estimate_C == pytest.approx(30.0)
    # an object touches: the flux jumps, contact is detected, the probe's own estimate goes out
    r = step(S(t=0.01, T=29.0, Q=3.0), PeerValues(33.5, 0.0), ps, r.state)
    assert r.status.contact and r.out.estimate_C == pytest.approx(29.0 - 1.5 * ps.R_sensor_K_per_W)
    # a bad peer value is never echoed
    ps2 = CoreParams(role=Role.SLAVE, echo_peer_when_free=True)
    r = step(S(T=30.0), PeerValues(math.nan, 0.0), ps2, init_state(ps2, None, S(T=30.0)))
    assert r.out.estimate_C == pytest.approx(30.0)


def test_model_estimator_with_the_shipped_narma_model():
    """The paper's estimator with telethermo.ident's streaming predictor: eq. 30 and the predictor's
    own free run; step() stays pure (the predictor's snapshot/restore travel in the state)."""
    ident = pytest.importorskip("telethermo.ident")
    model = ident.load_model(ident.default_model_path())
    p = CoreParams(role=Role.MASTER, estimator=Estimator.MODEL)
    s0 = init_state(p, model, S(T=26.0))
    ref = model.temperature.predictor(T0_C=26.0)
    r = step(S(T=26.0, I=0.0), PeerValues(26.0, 0.0), p, s0)
    currents = [r.current_A]
    for k in range(1, 50):
        r_prev = r
        r = step(S(t=0.01 * k, T=26.2, I=currents[-1]), PeerValues(27.0, 0.0), p, r.state)
        T_pred = ref.step(currents[-1])
        assert r.status.T_pred_C == pytest.approx(T_pred, abs=1e-12)
        assert r.status.estimate_C == pytest.approx(2 * 26.2 - T_pred, abs=1e-12)  # guiatni eq. 30
        currents.append(r.current_A)
    again = step(S(t=0.49, T=26.2, I=currents[-2]), PeerValues(27.0, 0.0), p, r_prev.state)
    assert again.status == r.status and again.current_A == r.current_A


def test_a_predictor_without_snapshot_makes_states_single_use():
    class Lag:  # a first-order TEM plate model (°C per A·s), no snapshot support
        def __init__(self):
            self.T = 0.0

        def reset(self, T_C):
            self.T = T_C

        def step(self, current_A):
            self.T += 0.04 * current_A
            return self.T

    p = CoreParams(role=Role.MASTER, estimator=Estimator.MODEL)
    s0 = init_state(p, Lag(), S(T=26.0))
    r1 = step(S(T=26.0), PeerValues(26.0, 0.0), p, s0)
    r2 = step(S(t=0.01, T=26.0, I=0.5), PeerValues(26.0, 0.0), p, r1.state)
    assert r2.status.T_pred_C == pytest.approx(26.02)
    with pytest.raises(RuntimeError, match="already used"):
        step(S(t=0.01, T=26.0, I=0.5), PeerValues(26.0, 0.0), p, r1.state)


def test_a_fault_reset_does_not_restart_an_identification_experiment():
    from telethermo.control.core import clear_faults
    from telethermo.ident.plan import IdentifyPlan

    p = CoreParams(
        role=Role.MASTER,
        mode=Mode.IDENTIFY,
        identify=IdentifyPlan(rest_samples=5, train_samples=100, validation_samples=50),
    )
    r = step(S(), None, p, init_state(p, None, S()))
    for k in range(1, 20):
        r = step(S(t=0.01 * k), None, p, r.state)
    r = step(S(t=0.2, sink=60.0), None, p, r.state)  # a heat-sink trip cuts the current
    assert r.current_A == 0.0 and r.state.env.trips
    st = clear_faults(S(t=0.21), None, p, r.state)  # the sink back to 25 °C: the operator resets
    assert not st.env.trips
    r = step(S(t=0.21), None, p, st)
    assert r.state.ident_k == 22  # the plan goes on (it does not restart at 0)


@settings(max_examples=150, deadline=None)
@given(
    seq=st.lists(
        st.tuples(
            st.floats(15, 43),
            st.floats(-3, 3),
            st.floats(-20, 50),
            st.floats(-10, 10),
            st.sampled_from(["ok", "ok", "ok", "lost", "nan", "stale"]),
            st.booleans(),
        ),
        min_size=5,
        max_size=80,
    ),
    kp=st.floats(0, 20),
    ki=st.floats(0, 50),
    kq=st.floats(-5, 5),
    kpq=st.floats(0, 5),
)
def test_peer_trips_never_step_the_current_beyond_the_slew(seq, kp, ki, kq, kpq):
    """Random gains, contacts (flux, the contact flag), peers (values, loss, NaN, stale) through the whole
    core:
    while a peer trip is latched and no hard cut, the commanded current falls towards 0 A or grows by at most
    trip_slew_A_per_s·period_s per step; |I| <= I_limit_A and the setpoint within [15, 43] °C always."""
    p = CoreParams(role=Role.MASTER, kp_A_per_C=kp, ki_A_per_C_s=ki, kQ_A_per_W=kq, kpQ_A_per_W=kpq)
    lim = p.safety
    step_A = lim.trip_slew_A_per_s * p.period_s
    r = step(S(), PeerValues(33.0, 0.0), p, init_state(p, None, S()))
    for k, (T, Q, pe, pq, kind, contact) in enumerate(seq, start=1):
        peer = {
            "ok": PeerValues(pe, pq),
            "lost": PeerValues(pe, pq, fresh=False, alive=False),
            "nan": PeerValues(math.nan, pq),
            "stale": PeerValues(pe, pq, fresh=False),
        }[kind]
        prev = r.current_A
        r = step(S(t=0.01 * k, T=T, Q=Q, I=prev, contact=contact), peer, p, r.state)
        I = r.current_A
        assert math.isfinite(I) and abs(I) <= lim.I_limit_A + 1e-12
        assert 15.0 <= r.status.setpoint_C <= 43.0
        trips = set(r.status.trips)
        if trips & {Trip.PEER_LOST, Trip.PEER_INVALID} and not trips - {Trip.PEER_LOST, Trip.PEER_INVALID}:
            assert min(prev, 0.0) - step_A - 1e-12 <= I <= max(prev, 0.0) + step_A + 1e-12, (prev, I, trips)


@settings(max_examples=150, deadline=None)
@given(
    valid=st.lists(st.floats(15, 43), min_size=1, max_size=20),
    own=st.lists(st.tuples(st.floats(15, 43), st.floats(-3, 3)), min_size=5, max_size=80),
    pattern=st.lists(st.sampled_from(["frozen", "stale", "burst"]), min_size=5, max_size=80),
)
def test_a_starved_peer_cannot_make_the_setpoint_climb(valid, own, pattern):
    """The flood aftermath (issue 12): a peer alive but starved never drives the master's setpoint beyond the
    values
    it was given. Values frozen or stale (fresh False): the setpoint moves towards the last one, never past
    it;
    old values re-delivered in bursts as if fresh: the setpoint stays within [min, max] of the setpoint when
    the
    starvation began and the values received. Any pad temperature, flux, gains of the shipped master."""
    p = dataclasses.replace(default_params(Role.MASTER, period_s=0.01), air_rendering=False)
    r = step(S(contact=True), PeerValues(33.0, 0.0), p, init_state(p, None, S(contact=True)))
    history = []
    for k, T_o in enumerate(valid, start=1):
        history.append(PeerValues(T_o, 0.0))
        r = step(S(t=0.01 * k, contact=True), history[-1], p, r.state)
    sp0, last = r.status.setpoint_C, history[-1]
    lo, hi = min([sp0] + [h.estimate_C for h in history]), max([sp0] + [h.estimate_C for h in history])
    sp = sp0
    for i, (kind, (T, Q)) in enumerate(zip(pattern, own)):
        peer = {
            "frozen": last,
            "stale": dataclasses.replace(last, fresh=False),
            "burst": history[i % len(history)],
        }[kind]
        r = step(S(t=0.01 * (len(valid) + 1 + i), T=T, Q=Q, contact=True), peer, p, r.state)
        new = r.status.setpoint_C
        assert not (set(r.status.trips) & {Trip.PEER_LOST, Trip.PEER_INVALID})
        assert lo - 1e-9 <= new <= hi + 1e-9
        if kind != "burst" and all(k != "burst" for k in pattern[:i]):
            P = last.estimate_C
            assert abs(new - P) <= abs(sp - P) + 1e-9 and (new - P) * (sp - P) >= -1e-12
        sp = new
