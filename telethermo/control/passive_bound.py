"""The master's passive bound in telepresence (issue 22): a passive object cannot push the operator's skin
past where the touch found it.

A finger touching an object colder than itself cools; nothing in the object can warm the skin above the
temperature it had when the touch began (nor, for a hotter object, cool it below). In telepresence the two
rigs can: each side tracks an estimate of the other body, and where the object barely anchors the exchange
(a thin plate on an insulator) the pair's common mode drifts. Envelope condition 160 (0.48 mm brass, copper
and alumina in a 29 °C room, 56 ms delay): the probe, following the display's finger estimate, heats the
plate, the display follows the plate up, and the operator's skin climbs to 37.5 °C while the direct touch
sits at 30–32 °C (docs/control.md, "The passive bound").

The bound: a touch's side is decided by the heat the probe gave the object in its first :data:`DECIDE_S`
(> 0: the object is colder than the probe that follows the finger); from then until the probe lifts, the
display's contact target stays at or below the finger's temperature when the touch began (at or above it for
a hotter object). That start is taken no nearer the object than the skin's neutral temperature, because a
skin cooled by the previous touch rewarms in contact (perfusion) as the direct finger does. Pure functions;
the master's core applies :func:`bounded_target` to its contact request (core.py).

    st = PassiveBoundState()
    st = bound_step(st, probe_touching=True, finger_C=33.6, probe_flux_W=0.8, dt_s=0.01)  # each period
    req_C = bounded_target(st, req_C, neutral_C=32.0)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: the touch's side is decided on the heat of its first DECIDE_S seconds, s (10 periods at 10 ms: long
#: enough to average the flux sensor's noise, short against the drift the bound is for)
DECIDE_S = 0.1


@dataclass(frozen=True, slots=True)
class PassiveBoundState:
    """One touch's memory: whether the probe touches, the finger estimate when it began (°C), the heat the
    probe has given the object since (J), the time since (s) and the side (+1: the object is colder, it took
    heat; -1: hotter; 0: not decided yet)."""

    touching: bool = False
    start_C: float = math.nan
    heat_J: float = 0.0
    elapsed_s: float = 0.0
    side: int = 0


def bound_step(
    st: PassiveBoundState, probe_touching: bool, finger_C: float, probe_flux_W: float, dt_s: float
) -> PassiveBoundState:
    """One period. ``probe_touching``: the probe reports contact; ``finger_C``: the master's finger estimate,
    °C; ``probe_flux_W``: the probe's flux, > 0 into the object, W; ``dt_s``: the period, s. A touch begins
    when the probe starts touching (its start: ``finger_C`` then) and ends when it lifts.

    >>> st = PassiveBoundState()
    >>> for _ in range(10):
    ...     st = bound_step(st, True, 33.6, 0.8, 0.01)   # the probe gives a cold object 0.8 W
    >>> st.side, st.start_C
    (1, 33.6)
    >>> bound_step(st, False, 30.0, 0.0, 0.01).touching
    False
    """
    if not probe_touching:
        return PassiveBoundState() if st.touching else st
    if not st.touching:
        st = PassiveBoundState(touching=True, start_C=float(finger_C))
    heat = st.heat_J + (float(probe_flux_W) * dt_s if math.isfinite(probe_flux_W) else 0.0)
    elapsed = st.elapsed_s + dt_s
    side = st.side
    if side == 0 and elapsed >= DECIDE_S - 1e-9 and heat != 0.0:
        side = 1 if heat > 0.0 else -1
    return PassiveBoundState(True, st.start_C, heat, elapsed, side)


def bounded_target(st: PassiveBoundState, req_C: float, neutral_C: float) -> float:
    """The contact target ``req_C`` (°C) bounded for the touch's side: at most max(start, ``neutral_C``) for a
    colder object, at least min(start, ``neutral_C``) for a hotter one; unchanged before the side is decided
    or without a finite start.

    >>> cold = PassiveBoundState(True, 34.8, 0.1, 0.2, 1)
    >>> bounded_target(cold, 37.5, 32.0), bounded_target(cold, 30.0, 32.0)
    (34.8, 30.0)
    >>> bounded_target(PassiveBoundState(True, 30.5, -0.1, 0.2, -1), 29.0, 32.0)   # hot object, cooled skin
    30.5
    """
    if st.side == 0 or not math.isfinite(st.start_C) or not math.isfinite(req_C):
        return req_C
    if st.side > 0:
        return min(req_C, max(st.start_C, neutral_C))
    return max(req_C, min(st.start_C, neutral_C))
