"""The envelope's current limit (DESIGN.md §6): the surface guard with its taper, the flux guard, the
trip slew and |I| <= 0.8·Imax. :func:`limit_current` decides the current that reaches the TEM, after
:func:`telethermo.control.safety.envelope_step` has judged the step; it is a pure function of (limits,
envelope state, request, credible surface band, previous current, measured flux)."""

from __future__ import annotations

import math

from telethermo.control.envelope_state import EnvelopeState
from telethermo.control.safety_limits import SafetyLimits
from telethermo.control.trips import CUT_TRIPS, PEER_TRIPS

__all__ = ["FLUX_GUARD_START", "FLUX_GUARD_STOP", "slewing", "limit_current"]


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
    outward current is capped linearly (full at the band's inner edge). Then |I| <= I_limit_A, and a
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
