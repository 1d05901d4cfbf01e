"""The envelope's current limit (DESIGN.md §6): the surface guard with its taper, the flux guard, the
trip slew and |I| <= 0.8·Imax. :func:`limit_current` decides the current that reaches the TEM, after
:func:`telethermo.control.safety.envelope_step` has judged the step; it is a pure function of (limits,
envelope state, request, credible surface band, previous current, measured flux)."""

from __future__ import annotations

import math

from telethermo.control.envelope_state import EnvelopeState
from telethermo.control.safety_limits import SafetyLimits
from telethermo.control.trips import CUT_TRIPS, PEER_TRIPS

__all__ = ["FLUX_GUARD_START", "FLUX_GUARD_STOP", "RATE_FILTER_S", "slewing", "limit_current", "stack_rates"]

#: the time constant of the first-order filter on the pad stack's rate (:func:`stack_rates`), s: three periods
#: at 10 ms, so one sample's noise moves the guard's lead by a quarter of its one-step slope
RATE_FILTER_S = 0.03


def stack_rates(state: EnvelopeState, hi_C: float, lo_C: float, dt_s: float) -> tuple[float, float]:
    """The filtered rates (hi, lo) of the pad stack's band, °C/s, from the previous step's band in
    ``state`` (0 where either step is not finite or ``dt_s`` is 0: no lead without a slope).

    >>> st = EnvelopeState(stack_prev_C=(40.0, 39.0), stack_rate_C_per_s=(0.0, 0.0))
    >>> [round(r, 6) for r in stack_rates(st, 40.4, 39.0, 0.01)]  # 40 °C/s: a quarter of it after one step
    [10.0, 0.0]
    """
    a = dt_s / (dt_s + RATE_FILTER_S) if dt_s > 0.0 else 0.0
    out = []
    for prev, now, r in zip(state.stack_prev_C, (hi_C, lo_C), state.stack_rate_C_per_s):
        ok = a > 0.0 and math.isfinite(prev) and math.isfinite(now)
        out.append(r + a * ((now - prev) / dt_s - r) if ok else 0.0)
    return out[0], out[1]


def _outward_cap(limits: SafetyLimits, room_C: float) -> float:
    """Largest current driving the surface outwards with ``room_C`` left to the guard's stop, A (>= 0)."""
    lim = limits.I_limit_A
    if room_C <= 0.0:
        return 0.0
    return lim if limits.taper_C <= 0.0 or room_C >= limits.taper_C else lim * room_C / limits.taper_C


#: the flux guard (:func:`limit_current`): the current that drives the heat flux outwards is tapered from
#: this fraction of ``Q_abs_max_W`` to 0 at :data:`FLUX_GUARD_STOP`, so that a big module pressed on a cold
#: or hot metal block saturates below the flux plausibility trip instead of ending the session there
FLUX_GUARD_START = 0.8
FLUX_GUARD_STOP = 0.95


def _flux_cap(limits: SafetyLimits, Q_out_W: float) -> float:
    """Largest current driving the flux further outwards when ``Q_out_W`` already flows that way, A."""
    q_max = limits.Q_abs_max_W
    room = (FLUX_GUARD_STOP * q_max - Q_out_W) / ((FLUX_GUARD_STOP - FLUX_GUARD_START) * q_max)
    return limits.I_limit_A * min(max(room, 0.0), 1.0) if math.isfinite(Q_out_W) else 0.0


def slewing(state: EnvelopeState) -> bool:
    """The trip slew limit applies: a peer trip is latched or the link-loss fallback renders, and no hard cut
    (:data:`CUT_TRIPS`)."""
    return bool(state.trips & PEER_TRIPS or state.link_fallback) and not state.trips & CUT_TRIPS


def limit_current(
    limits: SafetyLimits,
    state: EnvelopeState,
    requested_A: float,
    surface_hi_C: float,
    surface_lo_C: float,
    previous_A: float = math.nan,
    dt_s: float = 0.0,
    Q_W: float = 0.0,
) -> tuple[float, tuple[str, ...]]:
    """The current that may reach the TEM, A, and the limits that acted.

    NaN/inf requests give 0 A. Cut -> 0 A. Within ``guard_C`` of T_max_C only cooling (I <= 0) passes,
    within ``guard_C`` of T_min_C only heating (I >= 0); over the ``taper_C`` band before that the
    outward current is capped linearly (full at the band's inner edge). The surface band is first moved
    ``guard_lead_s`` ahead along the pad stack's rate towards the clamp it approaches
    (``state.stack_rate_C_per_s``, :func:`stack_rates`): the heat already between the plate and the skin
    arrives after the current has stopped. Then |I| <= I_limit_A, and a
    cooling current (I < 0) |I| <= I_cool_limit_A (the TEM's maximum-cooling current, where known).
    The flux guard ("guard"): with ``Q_W`` (the measured flux out of the pad, W) beyond
    :data:`FLUX_GUARD_START`·Q_abs_max_W, the current pushing it further (heating while Q_W > 0, cooling
    while Q_W < 0) is tapered to 0 A at :data:`FLUX_GUARD_STOP`·Q_abs_max_W.

    Trip slew: while :func:`slewing` and ``previous_A`` (the current of the previous step, A) is finite, the
    result may fall towards 0 A at once (as a cut does) but grows beyond ``previous_A`` (or beyond 0 A in the
    other direction) by at most ``trip_slew_A_per_s``·``dt_s`` ("slew"): the feed-forward that a peer trip
    removes can no longer flip the drive from full cooling to full heating in one step. The guard's and the
    current limit's caps still act at once. A hard cut (:data:`CUT_TRIPS`), a non-finite request or surface
    band give 0 A at once. The link-loss fallback (``state.link_fallback``) slews the same way
    (:func:`slewing`).
    """
    slew = slewing(state) and math.isfinite(previous_A) and dt_s > 0.0
    if (state.cut and not slew) or not math.isfinite(requested_A):
        return 0.0, ("cut",)
    if not (math.isfinite(surface_hi_C) and math.isfinite(surface_lo_C)):
        return 0.0, ("cut",)
    active: list[str] = []
    lim, cool = limits.I_limit_A, limits.I_cool_limit_A
    r_hi, r_lo = state.stack_rate_C_per_s
    surface_hi_C += limits.guard_lead_s * max(r_hi, 0.0)
    surface_lo_C += limits.guard_lead_s * min(r_lo, 0.0)
    hi_cap = min(
        lim, _outward_cap(limits, limits.T_max_C - limits.guard_C - surface_hi_C), _flux_cap(limits, Q_W)
    )
    lo_cap = min(
        cool, _outward_cap(limits, surface_lo_C - (limits.T_min_C + limits.guard_C)), _flux_cap(limits, -Q_W)
    )
    i = 0.0 if state.cut else requested_A
    if slew:  # towards 0 A at once (as a cut), away from it (beyond the previous current) at the slew rate
        step = limits.trip_slew_A_per_s * dt_s
        slewed = min(max(i, min(previous_A, 0.0) - step), max(previous_A, 0.0) + step)
        if slewed != i:
            i = slewed
            active.append("slew")
    if state.cut:
        active.append("cut")
    if i > hi_cap:
        active.append("guard" if hi_cap < lim else "current_limit")
        i = hi_cap
    elif i < -lo_cap:
        active.append("guard" if lo_cap < cool else "current_limit")
        i = -lo_cap
    return i, tuple(active)
