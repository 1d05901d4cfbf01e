"""The safety envelope: an independent layer below every controller (DESIGN.md §6).

A person's skin is on the display. Whatever a controller asks, :func:`envelope_step` decides the
setpoint the controller may track and :func:`limit_current` decides the current that reaches the
TEM. Both are pure functions of (limits, envelope state, measurements, request).

What the envelope enforces (defaults in :class:`SafetyLimits`):

- **setpoint clamp** to [T_min_C, T_max_C] = [15, 43] °C (only narrower unless ``research=True``);
- **ramp limit** on the setpoint (°C/s), separately for rises and drops;
- **time at temperature**: after ``hot_time_limit_s`` continuously above ``hot_C`` (41 °C) the
  setpoint is capped below ``hot_C`` (trip TIME_AT_TEMPERATURE);
- **surface guard**: when the pad surface (the highest/lowest of the sensor and the estimates) is
  within ``guard_C`` of a clamp the current may only drive it back inside (no heating near 43 °C,
  no cooling near 15 °C); beyond the clamp + ``surface_trip_margin_C`` the current is cut (trip);
- **current limit** |I| <= current_fraction·I_max_A (0.8·Imax);
- **heat-sink trip** at ``sink_trip_C`` (55 °C): current cut;
- **sensor plausibility**: NaN/inf, open thermocouple (a reading at or beyond ``open_tc_C``),
  out of the plausible range, absurd heat flux, model-vs-sensor mismatch held for
  ``mismatch_time_s``: current cut;
- **sensor off the pad**: with the pad steady by its sensor, a current far from what holding it against the
  measured load takes (:mod:`telethermo.control.detach`), counted for ``detach_time_s``: current cut;
- **peer**: lost (heartbeat/PDO timeout) or non-finite/absurd values: the setpoint ramps to
  ``neutral_C`` (32 °C) and then the current is cut. A bad peer value never reaches the command;
- **trip slew**: while a peer trip is latched (its ramp to neutral and the cut that ends it), and while the
  master's link-loss fallback renders (``EnvelopeInput.link_fallback``: it too drops telepresence's
  feed-forward and flux terms in one step), the current
  may fall towards 0 A at once but grows (beyond the previous step's, or beyond 0 A the other way) at most
  at ``trip_slew_A_per_s`` (:func:`limit_current` with ``previous_A``), and the neutral ramp's setpoint
  leads the credible surface by at most ``trip_lead_C``. The peer trip removes the controller's
  feed-forward and flux terms in one step (up to the whole current range: full cooling to full heating);
  without these two the pad surface then moves faster than the setpoint's ramp limit (measured:
  bench/stress_slew.py). The hard cuts (:data:`CUT_TRIPS`: sensor, over-temperature, surface
  beyond a clamp, overcurrent), a non-finite request and the surface guard act at once, slew or not.

Every trip has a CiA 301 emergency error code (:data:`EMCY_CODES`) and the bits it sets in the
error register 0x1001 (:data:`ERROR_REGISTER_BITS`). Trips latch: they stay active until
:func:`clear_trips` is called while their condition is gone (an operator's fault reset). The
status lists ``new_trips`` (raised in this very step: send one EMCY each) and ``cleared_trips``
(send the "error reset" EMCY 0x0000 when ``trips`` becomes empty).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from telethermo.control.current_guard import (
    FLUX_GUARD_START,
    FLUX_GUARD_STOP,
    limit_current,
    slewing,
    stack_rates,
)
from telethermo.control.detach import detach_excess, detach_timer, sensor_average
from telethermo.control.envelope_state import EnvelopeState, EnvelopeStatus, SafetyState, summarize
from telethermo.control.safety_limits import (
    DEFAULT_T_MAX_C,
    DEFAULT_T_MIN_C,
    DEFAULT_TRIP_LEAD_C,
    DEFAULT_TRIP_SLEW_A_PER_S,
    PROBE_T_MAX_C,
    PROBE_T_MIN_C,
    PROTECTS,
    LIMIT_NAMES,
    SafetyLimits,
    limits_from_mask,
    limits_mask,
    probe_limits,
)
from telethermo.control.trips import (
    CUT_TRIPS,
    EMCY_CODES,
    ERROR_REGISTER_BITS,
    PEER_TRIPS,
    ErrorRegisterBit,
    Trip,
    error_register,
    trips_from_mask,
    trips_mask,
)


# The public names, with those re-exported from trips, safety_limits, envelope_state and current_guard (the
# envelope's one import point).
__all__ = [
    # trips
    "CUT_TRIPS",
    "EMCY_CODES",
    "ERROR_REGISTER_BITS",
    "PEER_TRIPS",
    "ErrorRegisterBit",
    "Trip",
    "error_register",
    "trips_from_mask",
    "trips_mask",
    # safety_limits
    "DEFAULT_T_MAX_C",
    "DEFAULT_T_MIN_C",
    "DEFAULT_TRIP_LEAD_C",
    "DEFAULT_TRIP_SLEW_A_PER_S",
    "PROBE_T_MAX_C",
    "PROBE_T_MIN_C",
    "PROTECTS",
    "SafetyLimits",
    "probe_limits",
    "LIMIT_NAMES",
    "limits_from_mask",
    "limits_mask",
    # envelope_state
    "SafetyState",
    "EnvelopeState",
    "EnvelopeStatus",
    "summarize",
    # current_guard
    "FLUX_GUARD_START",
    "FLUX_GUARD_STOP",
    "slewing",
    "limit_current",
    # this module
    "check_sample",
    "peer_valid",
    "EnvelopeInput",
    "envelope_step",
    "clear_trips",
]


def _finite(*xs: float) -> bool:
    isf = math.isfinite
    for x in xs:
        if not isf(x):
            return False
    return True


def check_sample(
    limits: SafetyLimits, T_sensor_C: float, Q_W: float, T_sink_C: float, current_A: float
) -> set[Trip]:
    """Plausibility trips of one rig sample (pure)."""
    trips: set[Trip] = set()
    if not _finite(T_sensor_C, Q_W, T_sink_C, current_A):
        trips.add(Trip.SENSOR_INVALID)
        return trips
    if abs(T_sensor_C) >= limits.open_tc_C or abs(T_sink_C) >= limits.open_tc_C:
        trips.add(Trip.OPEN_THERMOCOUPLE)
    elif not (
        limits.sensor_min_C <= T_sensor_C <= limits.sensor_max_C
        and limits.sensor_min_C <= T_sink_C <= limits.sensor_max_C
    ):
        trips.add(Trip.SENSOR_RANGE)
    if abs(Q_W) > limits.Q_abs_max_W:
        trips.add(Trip.SENSOR_RANGE)
    if T_sink_C >= limits.sink_trip_C and Trip.OPEN_THERMOCOUPLE not in trips:
        trips.add(Trip.HEAT_SINK)
    if abs(current_A) > 1.05 * limits.I_max_A:
        trips.add(Trip.OVERCURRENT)
    return trips


def peer_valid(limits: SafetyLimits, estimate_C: float, flux_W: float) -> bool:
    """True if the peer's values are finite and plausible."""
    return (
        _finite(estimate_C, flux_W)
        and limits.peer_T_min_C <= estimate_C <= limits.peer_T_max_C
        and abs(flux_W) <= limits.peer_Q_abs_max_W
    )


@dataclass(frozen=True, slots=True)
class EnvelopeInput:
    """The measurements the envelope judges in one step.

    Attributes:
        T_sensor_C, Q_W, T_sink_C, current_meas_A: the rig sample.
        surface_hi_C, surface_lo_C: highest and lowest credible pad-surface temperature, °C
            (max/min of the sensor and the estimates); NaN if unknown.
        T_pred_C: the model's prediction, °C (NaN: no mismatch check).
        peer_required: the mode needs a peer (telepresence).
        peer_alive, peer_ok: the node's link state; the peer's values are finite and plausible.
        link_fallback: the master renders locally because the slave is lost (issue 15's graceful link loss):
            the same trip slew and lead bound as under a peer trip apply (its start replaces telepresence's
            feed-forward and flux terms in one step, as a peer trip does).
        stack_hi_C, stack_lo_C: highest and lowest temperature of the pad stack (the sensor, both its faces
            and the estimates), °C, whose rate gives the guard its lead (``SafetyLimits.guard_lead_s``); NaN:
            the surface band's.
    """

    T_sensor_C: float
    Q_W: float
    T_sink_C: float
    current_meas_A: float
    surface_hi_C: float
    surface_lo_C: float
    T_pred_C: float
    peer_required: bool
    peer_alive: bool
    peer_ok: bool
    link_fallback: bool = False
    stack_hi_C: float = math.nan
    stack_lo_C: float = math.nan


def _judge_sample(
    limits: SafetyLimits, state: EnvelopeState, inp: EnvelopeInput, dt_s: float
) -> tuple[set[Trip], float, float, float]:
    """The trips this step's measurements raise, and the new mismatch, hot and detach timers, s."""
    raised = set(check_sample(limits, inp.T_sensor_C, inp.Q_W, inp.T_sink_C, inp.current_meas_A))

    # surface beyond the clamps (by more than the margin): cut
    if math.isfinite(inp.surface_hi_C) and inp.surface_hi_C > limits.T_max_C + limits.surface_trip_margin_C:
        raised.add(Trip.SURFACE_HIGH)
    if math.isfinite(inp.surface_lo_C) and inp.surface_lo_C < limits.T_min_C - limits.surface_trip_margin_C:
        raised.add(Trip.SURFACE_LOW)

    # model vs sensor mismatch, held for mismatch_time_s
    mismatch_time = state.mismatch_time_s
    if (
        math.isfinite(inp.T_pred_C)
        and math.isfinite(inp.T_sensor_C)
        and abs(inp.T_pred_C - inp.T_sensor_C) > limits.mismatch_C
    ):
        mismatch_time += dt_s
        if mismatch_time >= limits.mismatch_time_s:
            raised.add(Trip.MODEL_MISMATCH)
    else:
        mismatch_time = 0.0

    # time at temperature
    hot_time = state.hot_time_s
    if math.isfinite(inp.surface_hi_C) and inp.surface_hi_C > limits.hot_C:
        hot_time += dt_s
        if hot_time >= limits.hot_time_limit_s:
            raised.add(Trip.TIME_AT_TEMPERATURE)
    else:
        hot_time = 0.0

    # a sensor off the pad: far more current than holding the last setpoint takes, held (control.detach)
    excess = not state.cut and detach_excess(
        limits,
        T_sensor_C=inp.T_sensor_C,
        T_avg_C=state.sensor_avg_C,
        current_A=inp.current_meas_A,
        T_sink_C=inp.T_sink_C,
        Q_W=inp.Q_W,
    )
    detach_time, detached = detach_timer(limits, state.detach_time_s, excess, dt_s)
    if detached:
        raised.add(Trip.SENSOR_DETACHED)

    # peer
    if inp.peer_required:
        if not inp.peer_alive:
            raised.add(Trip.PEER_LOST)
        elif not inp.peer_ok:
            raised.add(Trip.PEER_INVALID)
    return raised, mismatch_time, hot_time, detach_time


def _lead_bound(limits: SafetyLimits, prev_C: float, sp_C: float, inp: EnvelopeInput) -> float:
    """The neutral ramp's setpoint, °C, kept within ``trip_lead_C`` ahead of the credible surface in the
    direction it moves (it waits for a pad that lags, it never moves back): the controller's error stays
    small, so the surface does not overshoot the ramp's rate catching up a setpoint that ran away."""
    lead = limits.trip_lead_C
    if not (math.isfinite(inp.surface_hi_C) and math.isfinite(inp.surface_lo_C)) or lead == math.inf:
        return sp_C
    if sp_C > prev_C:
        return max(prev_C, min(sp_C, inp.surface_lo_C + lead))
    if sp_C < prev_C:
        return min(prev_C, max(sp_C, inp.surface_hi_C - lead))
    return sp_C


def envelope_step(
    limits: SafetyLimits, state: EnvelopeState, inp: EnvelopeInput, requested_C: float, dt_s: float
) -> tuple[float, EnvelopeState, tuple[str, ...], frozenset[Trip]]:
    """Judge one step: raise trips, ramp/clamp the requested setpoint.

    Returns ``(setpoint_C, new_state, limits_active, new_trips)``. The setpoint is always finite and
    inside [T_min_C, T_max_C], even if ``requested_C`` is NaN (then the previous setpoint is held).
    """
    active: list[str] = []
    raised, mismatch_time, hot_time, detach_time = _judge_sample(limits, state, inp, dt_s)
    new_trips = frozenset(raised) - state.trips
    trips = state.trips | frozenset(raised)

    # the setpoint: start from the previous ramped value (or the credible surface at start)
    prev = state.setpoint_C
    if prev is None or not math.isfinite(prev):
        mid = 0.5 * (inp.surface_hi_C + inp.surface_lo_C)
        prev = mid if math.isfinite(mid) else limits.neutral_C
        prev = min(max(prev, limits.T_min_C), limits.T_max_C)

    target = requested_C if math.isfinite(requested_C) else prev
    neutral_time = state.neutral_time_s
    peer_trip = bool(trips & PEER_TRIPS)
    if peer_trip:
        target = limits.neutral_C
        neutral_time += dt_s
        active.append("neutral_ramp")
    else:
        neutral_time = 0.0
    if Trip.TIME_AT_TEMPERATURE in trips and target > limits.hot_C - 1.0:
        target = limits.hot_C - 1.0
        active.append("hot_cap")
    clamped = min(max(target, limits.T_min_C), limits.T_max_C)
    if clamped != target:
        active.append("setpoint_clamp")
    up, down = limits.ramp_up_C_per_s * dt_s, limits.ramp_down_C_per_s * dt_s
    sp = min(max(clamped, prev - down), prev + up)
    if sp != clamped:
        active.append("ramp")
    if peer_trip or inp.link_fallback:
        sp = _lead_bound(limits, prev, sp, inp)

    cut = state.cut or bool(trips & CUT_TRIPS)
    stack = (
        (inp.stack_hi_C, inp.stack_lo_C)
        if math.isfinite(inp.stack_hi_C) and math.isfinite(inp.stack_lo_C)
        else (inp.surface_hi_C, inp.surface_lo_C)
    )
    if peer_trip and not cut:
        if abs(sp - limits.neutral_C) <= limits.neutral_tol_C or neutral_time >= limits.neutral_timeout_s:
            cut = True
    if cut:
        active.append("cut")
    new_state = EnvelopeState(
        setpoint_C=sp,
        trips=trips,
        hot_time_s=hot_time,
        mismatch_time_s=mismatch_time,
        neutral_time_s=neutral_time,
        cut=cut,
        link_fallback=inp.link_fallback,
        detach_time_s=detach_time,
        sensor_avg_C=sensor_average(state.sensor_avg_C, inp.T_sensor_C, dt_s),
        stack_prev_C=stack,
        stack_rate_C_per_s=stack_rates(state, stack[0], stack[1], dt_s),
    )
    return sp, new_state, tuple(active), new_trips


def clear_trips(limits: SafetyLimits, state: EnvelopeState, inp: EnvelopeInput) -> EnvelopeState:
    """Operator's fault reset: drop the latched trips whose condition is gone now.

    A trip whose condition cannot be observed while the current is cut (OVERCURRENT: the measured current
    is 0 A then) is acknowledged by the reset: if its cause is still there it trips again at the next
    sample that shows it.

    The cut is released only when no cut-trip remains and the peer is fine; the ramped setpoint
    restarts from the credible surface temperature (bumpless).
    """
    still = set(check_sample(limits, inp.T_sensor_C, inp.Q_W, inp.T_sink_C, inp.current_meas_A))
    if math.isfinite(inp.surface_hi_C) and inp.surface_hi_C > limits.T_max_C + limits.surface_trip_margin_C:
        still.add(Trip.SURFACE_HIGH)
    if math.isfinite(inp.surface_lo_C) and inp.surface_lo_C < limits.T_min_C - limits.surface_trip_margin_C:
        still.add(Trip.SURFACE_LOW)
    if (
        Trip.TIME_AT_TEMPERATURE in state.trips
        and math.isfinite(inp.surface_hi_C)
        and inp.surface_hi_C > limits.hot_C - 1.0
    ):
        still.add(Trip.TIME_AT_TEMPERATURE)
    # the model still disagrees with the sensor (or cannot say): the mismatch persists (a good model
    # loaded, or the sensor back, removes it); without a model there is nothing to mismatch
    T_pred = inp.T_pred_C
    if (
        Trip.MODEL_MISMATCH in state.trips
        and not math.isnan(T_pred)
        and (
            math.isinf(T_pred)
            or not math.isfinite(inp.T_sensor_C)
            or abs(T_pred - inp.T_sensor_C) > limits.mismatch_C
        )
    ):
        still.add(Trip.MODEL_MISMATCH)
    if inp.peer_required and not inp.peer_alive:
        still.add(Trip.PEER_LOST)
    elif inp.peer_required and not inp.peer_ok:
        still.add(Trip.PEER_INVALID)
    trips = state.trips & frozenset(still)
    cut = bool(trips & (CUT_TRIPS | PEER_TRIPS))
    mid = 0.5 * (inp.surface_hi_C + inp.surface_lo_C)
    sp = min(max(mid, limits.T_min_C), limits.T_max_C) if math.isfinite(mid) else state.setpoint_C
    return replace(
        state,
        trips=trips,
        cut=cut,
        setpoint_C=sp,
        mismatch_time_s=0.0,
        neutral_time_s=0.0,
        detach_time_s=0.0,
        hot_time_s=0.0 if Trip.TIME_AT_TEMPERATURE not in trips else state.hot_time_s,
    )
