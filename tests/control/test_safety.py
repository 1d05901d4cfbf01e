"""The safety envelope as a pure function: trips, EMCY codes, ramps, guards, peer loss."""

import dataclasses
import math

import pytest
from hypothesis import given, settings, strategies as st

from telethermo.control import safety as sf

L = sf.SafetyLimits(I_max_A=2.0)


def inp(T=33.0, Q=0.0, sink=26.0, I=0.0, hi=None, lo=None, Tp=math.nan, req=False, alive=True, ok=True):
    hi = T if hi is None else hi
    lo = T if lo is None else lo
    return sf.EnvelopeInput(T, Q, sink, I, hi, lo, Tp, req, alive, ok)


def run(limits, state, i, req, n, dt=0.01):
    out = []
    for _ in range(n):
        sp, state, act, new = sf.envelope_step(limits, state, i, req, dt)
        out.append((sp, act, new))
    return state, out


def test_limits_validation_names_the_field():
    with pytest.raises(ValueError, match=r"SafetyLimits.T_min_C/T_max_C: expected within \[15.0, 43.0\]"):
        sf.SafetyLimits(T_max_C=45.0)
    with pytest.raises(ValueError, match="current_fraction: expected <= 0.8"):
        sf.SafetyLimits(current_fraction=0.9)
    with pytest.raises(ValueError, match="I_max_A: expected a finite number"):
        sf.SafetyLimits(I_max_A=math.nan)
    assert sf.SafetyLimits(T_max_C=45.0, research=True).T_max_C == 45.0
    assert sf.SafetyLimits(T_min_C=20.0, T_max_C=40.0).T_max_C == 40.0  # narrower is fine


def test_every_trip_has_a_cia301_code_and_register_bits():
    from telethermo.device.emcy import register_bits

    for t in sf.Trip:
        code = sf.EMCY_CODES[t]
        assert 0x1000 <= code <= 0xFFFF and code >> 12 in (0x2, 0x4, 0x5, 0x8, 0xF)
        reg = sf.error_register(frozenset({t}))
        assert reg & sf.ErrorRegisterBit.GENERIC
        if t in sf.PEER_TRIPS:  # the core's 0x1001 is the device's for that code
            assert reg == register_bits(code), t
    assert sf.EMCY_CODES[sf.Trip.PEER_LOST] == 0x8130  # CiA 301 life guard / heartbeat error
    # a NaN peer value is no "PDO not processed due to length error" (0x8210, the device's own)
    assert sf.EMCY_CODES[sf.Trip.PEER_INVALID] == 0xFF02
    assert sf.error_register(frozenset({sf.Trip.HEAT_SINK})) == 0x09
    assert sf.error_register(frozenset({sf.Trip.PEER_LOST})) == 0x11
    assert sf.error_register(frozenset()) == 0


def test_setpoint_clamped_and_ramped_both_ways():
    st0 = sf.EnvelopeState(setpoint_C=33.0)
    s, out = run(L, st0, inp(), 60.0, 300)
    sps = [o[0] for o in out]
    assert max(sps) == pytest.approx(43.0)
    steps = [b - a for a, b in zip([33.0] + sps, sps)]
    assert max(steps) <= 5.0 * 0.01 + 1e-12
    assert sps[199] == pytest.approx(43.0) and sps[198] < 43.0  # 10 °C at 5 °C/s = 2 s
    s, out = run(L, s, inp(), -100.0, 600)
    assert out[-1][0] == pytest.approx(15.0)
    assert min(b - a for a, b in zip([o[0] for o in out][:-1], [o[0] for o in out][1:])) >= -0.05 - 1e-12


def test_nan_request_holds_the_setpoint():
    s, out = run(L, sf.EnvelopeState(setpoint_C=30.0), inp(), math.nan, 10)
    assert all(o[0] == 30.0 for o in out)


@pytest.mark.parametrize(
    "kw,trip",
    [
        (dict(T=math.nan), sf.Trip.SENSOR_INVALID),
        (dict(Q=math.inf), sf.Trip.SENSOR_INVALID),
        (dict(T=1370.0), sf.Trip.OPEN_THERMOCOUPLE),
        (dict(T=95.0), sf.Trip.SENSOR_RANGE),
        (dict(Q=40.0), sf.Trip.SENSOR_RANGE),
        (dict(sink=56.0), sf.Trip.HEAT_SINK),
        (dict(I=2.5), sf.Trip.OVERCURRENT),
        (dict(hi=45.5), sf.Trip.SURFACE_HIGH),
        (dict(lo=12.5), sf.Trip.SURFACE_LOW),
    ],
)
def test_cut_trips_cut_at_once_latch_and_report_once(kw, trip):
    s, out = run(L, sf.EnvelopeState(setpoint_C=33.0), inp(**kw), 33.0, 1)
    assert trip in s.trips and s.cut
    assert out[0][2] == frozenset({trip}) or trip in out[0][2]
    assert sf.limit_current(L, s, 1.0, 33.0, 33.0) == (0.0, ("cut",))
    # latched: a good sample does not release it, and the trip is not "new" again
    s2, out2 = run(L, s, inp(), 33.0, 5)
    assert trip in s2.trips and s2.cut and all(not o[2] for o in out2)
    # operator reset with the condition gone releases it
    s3 = sf.clear_trips(L, s2, inp())
    assert not s3.trips and not s3.cut
    # ... but not while the condition persists
    s4 = sf.clear_trips(L, s2, inp(**kw))
    assert trip in s4.trips


def test_mismatch_needs_to_persist():
    i = inp(T=33.0, Tp=20.0)  # 13 °C apart > 12 °C
    s, _ = run(L, sf.EnvelopeState(setpoint_C=33.0), i, 33.0, 99)
    assert sf.Trip.MODEL_MISMATCH not in s.trips
    s, _ = run(L, s, i, 33.0, 1)
    assert sf.Trip.MODEL_MISMATCH in s.trips and s.cut


def test_time_at_temperature_caps_setpoint_below_hot():
    lim = sf.SafetyLimits(hot_time_limit_s=1.0)
    s, out = run(lim, sf.EnvelopeState(setpoint_C=42.0), inp(T=42.0), 42.5, 99)
    assert sf.Trip.TIME_AT_TEMPERATURE not in s.trips and out[-1][0] == pytest.approx(42.5)
    s, out = run(lim, s, inp(T=42.0), 42.5, 200)
    assert sf.Trip.TIME_AT_TEMPERATURE in s.trips and not s.cut
    assert out[-1][0] == pytest.approx(40.0)


@pytest.mark.parametrize(
    "alive,ok,trip", [(False, True, sf.Trip.PEER_LOST), (True, False, sf.Trip.PEER_INVALID)]
)
def test_peer_trouble_ramps_to_neutral_then_cuts(alive, ok, trip):
    s, out = run(L, sf.EnvelopeState(setpoint_C=25.0), inp(req=True, alive=alive, ok=ok), 20.0, 1)
    assert trip in s.trips and not s.cut and out[0][0] == pytest.approx(25.05)
    s, out = run(L, s, inp(req=True, alive=alive, ok=ok), 20.0, 400)
    sps = [o[0] for o in out]
    assert all(b >= a - 1e-12 for a, b in zip(sps, sps[1:]))  # monotone towards 32 °C, never 20
    assert s.cut and abs(sps[-1] - 32.0) <= 0.3
    i, _ = sf.limit_current(L, s, 1.2, 32.0, 32.0)
    assert i == 0.0
    s2 = sf.summarize(s, frozenset(), ("cut",))
    assert s2.state is sf.SafetyState.CUT and s2.emcy_codes == (sf.EMCY_CODES[trip],)


def test_peer_validity():
    assert sf.peer_valid(L, 30.0, 1.0)
    for e, q in ((math.nan, 0.0), (math.inf, 0.0), (30.0, -math.inf), (1e6, 0.0), (-300.0, 0.0), (30.0, 1e4)):
        assert not sf.peer_valid(L, e, q)


@settings(max_examples=400, deadline=None)
@given(
    req=st.floats(allow_nan=True, allow_infinity=True),
    hi=st.floats(-50, 100),
    span=st.floats(0, 5),
    I=st.floats(allow_nan=True, allow_infinity=True),
)
def test_limit_current_never_exceeds_limit_nor_pushes_outward(req, hi, span, I):
    lo = hi - span
    s = sf.EnvelopeState(setpoint_C=33.0)
    i, _ = sf.limit_current(L, s, I, hi, lo)
    assert math.isfinite(i) and abs(i) <= L.I_limit_A
    if hi >= L.T_max_C - L.guard_C:
        assert i <= 0.0
    if lo <= L.T_min_C + L.guard_C:
        assert i >= 0.0


def test_fault_reset_keeps_a_model_mismatch_while_the_model_still_disagrees():
    """clear_trips (the operator's fault reset) keeps MODEL_MISMATCH while |T_pred - T_sensor| > mismatch_C
    or T_pred diverged; a model that agrees again (or no model: T_pred NaN) lets it go."""
    from telethermo.control.safety import EnvelopeInput, EnvelopeState, SafetyLimits, Trip, clear_trips

    lim = SafetyLimits()
    st = EnvelopeState(setpoint_C=30.0, trips=frozenset({Trip.MODEL_MISMATCH}), cut=True)

    def after(T_pred):
        inp = EnvelopeInput(30.0, 0.0, 25.0, 0.0, 30.0, 30.0, T_pred, False, False, False)
        return clear_trips(lim, st, inp)

    for bad in (30.0 + lim.mismatch_C + 0.5, 30.0 - lim.mismatch_C - 0.5, float("inf")):
        kept = after(bad)
        assert kept.trips == {Trip.MODEL_MISMATCH} and kept.cut
    for good in (30.0 + lim.mismatch_C - 0.5, float("nan")):
        gone = after(good)
        assert not gone.trips and not gone.cut


def test_trips_mask_round_trip_and_documented_bits():
    from telethermo.control.safety import Trip, trips_from_mask, trips_mask

    assert (
        trips_mask([Trip.HEAT_SINK]) == 0x080 and trips_mask([Trip.PEER_LOST, Trip.SENSOR_INVALID]) == 0x201
    )
    assert trips_mask([]) == 0
    every = list(Trip)
    assert trips_from_mask(trips_mask(every)) == every and trips_mask(every) == (1 << len(every)) - 1
    assert trips_from_mask(0x8000 | 0x008) == [Trip.MODEL_MISMATCH]  # unknown bits ignored


def _grows_within_slew(prev, i, step):
    """The trip slew's promise: towards 0 A at once, beyond the previous current (or 0 A) by <= step."""
    return min(prev, 0.0) - step - 1e-12 <= i <= max(prev, 0.0) + step + 1e-12


@settings(max_examples=300, deadline=None)
@given(
    seq=st.lists(
        st.tuples(
            st.floats(-5, 5),
            st.floats(10, 50),
            st.floats(0, 3),
            st.booleans(),
            st.booleans(),
            st.sampled_from(["ok", "ok", "ok", "nan_sensor", "hot_sink"]),
            st.booleans(),
        ),
        min_size=2,
        max_size=60,
    ),
    slew=st.floats(0.1, 20),
    lead=st.floats(0.1, 5),
    I0=st.floats(-1.6, 1.6),
)
def test_peer_trips_slew_the_current_and_the_envelope_holds(seq, slew, lead, I0):
    """Random requests (any controller, any gains), surfaces, peers, trips and link-loss fallbacks: while a
    peer
    trip is latched or the fallback renders, and no hard cut, the current falls to 0 A at once or grows at
    most
    trip_slew_A_per_s; a hard cut is 0 A at once; |I| <= I_limit_A, the setpoint within the clamps, no heating
    within guard_C of T_max_C."""
    lim = sf.SafetyLimits(I_max_A=2.0, trip_slew_A_per_s=slew, trip_lead_C=lead)
    dt = 0.01
    state, prev = sf.EnvelopeState(setpoint_C=33.0), I0
    for req_A, T, span, alive, ok, fault, fallback in seq:
        e = inp(
            T=math.nan if fault == "nan_sensor" else T,
            hi=T + span,
            lo=T,
            req=not fallback,
            alive=alive,
            ok=ok,
            sink=60.0 if fault == "hot_sink" else 26.0,
        )
        e = dataclasses.replace(e, link_fallback=fallback)
        if fault == "nan_sensor":
            e = dataclasses.replace(e, surface_hi_C=math.nan, surface_lo_C=math.nan)
        sp, state, _, _ = sf.envelope_step(lim, state, e, T, dt)
        i, act = sf.limit_current(lim, state, req_A, e.surface_hi_C, e.surface_lo_C, prev, dt)
        assert math.isfinite(i) and abs(i) <= lim.I_limit_A + 1e-12
        assert lim.T_min_C <= sp <= lim.T_max_C
        if state.trips & sf.CUT_TRIPS:
            assert i == 0.0
        elif state.trips & sf.PEER_TRIPS or fallback:
            assert _grows_within_slew(prev, i, slew * dt)
        if math.isfinite(e.surface_hi_C) and e.surface_hi_C >= lim.T_max_C - lim.guard_C:
            assert i <= 0.0
        prev = i


def test_the_neutral_ramp_waits_for_a_lagging_surface():
    """A peer trip with the pad at 18 °C: the setpoint leads the surface by at most trip_lead_C (it waits),
    and
    without the lead bound (research: inf) it runs ahead at the ramp limit."""
    for lead, expect in ((1.5, 18.0 + 1.5), (math.inf, 18.0 + 100 * 0.05)):
        lim = sf.SafetyLimits(I_max_A=2.0, trip_lead_C=lead, research=lead == math.inf)
        s, out = run(lim, sf.EnvelopeState(setpoint_C=18.0), inp(T=18.0, req=True, alive=False), 18.0, 100)
        assert out[-1][0] == pytest.approx(expect)
        assert all(b >= a for a, b in zip([o[0] for o in out], [o[0] for o in out][1:]))


def test_slew_off_needs_research_and_hard_cuts_stay_immediate():
    with pytest.raises(ValueError, match="trip_slew_A_per_s"):
        sf.SafetyLimits(trip_slew_A_per_s=math.inf)
    with pytest.raises(ValueError, match="trip_slew_A_per_s"):
        sf.SafetyLimits(trip_slew_A_per_s=0.0)
    s = sf.EnvelopeState(setpoint_C=30.0, trips=frozenset({sf.Trip.PEER_LOST}))
    # full cooling requested to full heating: only one slew step beyond 0 A
    i, act = sf.limit_current(L, s, 1.6, 30.0, 30.0, -1.6, 0.01)
    assert i == pytest.approx(L.trip_slew_A_per_s * 0.01) and "slew" in act
    # a hard cut on top of the peer trip: 0 A at once
    s2 = dataclasses.replace(s, trips=s.trips | {sf.Trip.HEAT_SINK}, cut=True)
    assert sf.limit_current(L, s2, 1.6, 30.0, 30.0, 1.6, 0.01) == (0.0, ("cut",))
    # the peer trip's own cut slews to 0 A? no: towards 0 A is immediate (as a cut), only growth is slewed
    s3 = dataclasses.replace(s, cut=True)
    assert sf.limit_current(L, s3, 1.6, 30.0, 30.0, 1.2, 0.01)[0] == 0.0
