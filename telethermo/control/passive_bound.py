"""The master's passive bound in telepresence (issue 22): a passive object cannot push the operator's skin
past where the touch found it.

A finger touching an object colder than itself cools; nothing in the object can warm the skin above the
temperature it had when the touch began (nor, for a hotter object, cool it below). In telepresence the two
rigs can: each side tracks an estimate of the other body, and where the object barely anchors the exchange
(a thin plate on an insulator) the pair's common mode drifts. Envelope condition 160 (0.48 mm brass, copper
and alumina in a 29 °C room, 56 ms delay): the probe, following the display's finger estimate, heats the
plate, the display follows the plate up, and the operator's skin climbs to 37.5 °C while the direct touch
sits at 30–32 °C (docs/control.md, "The passive bound").

The bound: a touch's side is decided by the heat the probe gave the object in its first :data:`DECIDE_S` (> 0:
the object is colder than the probe that follows the finger), and turned, once, if it was decided on less than
:data:`FLIP_J` and the touch's heat later goes :data:`FLIP_J` past zero the other way (a probe left hot by the
previous touch cools in its first moments on an insulator, and its flux estimate can read that as heat from
the object: held-out condition 48 decided EPS at 13.7 °C "hotter", and the display and probe climbed together
to 39 °C). From then until the probe lifts, the display's contact target stays at or below the finger's
temperature when the touch began (at or above it for a hotter object). That start is taken no nearer the
object than the skin's neutral temperature, because a skin cooled by the previous touch rewarms in contact
(perfusion) as the direct finger does.

The return: from the side's decision on, the target comes back at most :data:`RETURN_C` from the furthest it
has gone towards the object in the touch. After its first moments the probe's object estimate carries the
probe's own heat: the probe follows a finger estimate that the display's current and ramp limits hold back,
and gives a colder object several times the heat a finger would (condition 120, 1.1 mm alumina at 12.6 °C:
+3 A, the plate's face from 13 to 32 °C in 1.3 s while the direct touch's skin sits at 17–20 °C). On a
colder passive object the finger's contact temperature falls at once and comes back only as the finger's own
heat warms the object's face: on a 20 mm metal block by less than 1 °C (the base scene: the target's return
from its lowest is 0.92 °C), on a thin plate by more over the seconds of the touch, which the bound then
keeps nearer its extreme than the direct touch is (measured on the matrix with the flux below: the late
error's median change −0.09 °C, its worst +0.37 °C, condition 69, a 0.38 mm plate).

The flux: heat between a finger and a passive object flows one way, from the warmer body to the colder, for
the whole touch. The probe's does not: once its own heat has moved the object's face past the finger estimate
it follows (a hot brass block drained to 37 °C under a 41 °C finger estimate, condition 41), its flux turns,
and the display's mirror (eq. 34) would cool a finger that a 46 °C object is warming. From the side's
decision on, :func:`passive_flux_W` keeps the peer's flux on the side's sign (at 0 where it turns).

Pure functions; the master's core applies :func:`held_target` to its contact request and
:func:`passive_flux_W` to the flux it mirrors (core.py).

    st = PassiveBoundState()
    st = bound_step(st, probe_touching=True, finger_C=33.6, probe_flux_W=0.8, dt_s=0.01)  # each period
    req_C, st = held_target(st, req_C, neutral_C=32.0)
    flux_W = passive_flux_W(st, peer_flux_W)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

#: the touch's side is decided on the heat of its first DECIDE_S seconds, s (10 periods at 10 ms: long
#: enough to average the flux sensor's noise, short against the drift the bound is for)
DECIDE_S = 0.1
#: how far the contact target may come back from the furthest it has gone towards the object in a touch, °C
#: (the base scene's return is 0.92 °C; on the matrix 1.5 and 2.5 were measured, docs/control.md)
RETURN_C = 1.5
#: a side decided on less heat than this turns, once, when the touch's heat runs this far past zero the other
#: way, J; a side decided on more never turns (the median touch gives 0.037 J in its first DECIDE_S; a
#: fast-cooling probe's flux estimate can be that far off, docs/control.md)
FLIP_J = 0.03


@dataclass(frozen=True, slots=True)
class PassiveBoundState:
    """One touch's memory: whether the probe touches, the finger estimate when it began (°C), the heat the
    probe has given the object since (J), the time since (s), the side (+1: the object is colder, it took
    heat; -1: hotter; 0: not decided yet) and the furthest the bounded target has gone towards the object
    since the side was decided (°C; its lowest for a colder object, its highest for a hotter one), and the
    heat the side was decided on (J)."""

    touching: bool = False
    start_C: float = math.nan
    heat_J: float = 0.0
    elapsed_s: float = 0.0
    side: int = 0
    extreme_C: float = math.nan
    decided_J: float = 0.0


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
    >>> weak = PassiveBoundState()
    >>> for _ in range(10):
    ...     weak = bound_step(weak, True, 27.4, -0.16, 0.01)  # a probe cooling on EPS: -0.016 J, "hotter"
    >>> for _ in range(20):
    ...     weak = bound_step(weak, True, 27.4, 0.4, 0.01)    # then it gives the object 0.4 W
    >>> weak.side, round(weak.heat_J, 3)
    (1, 0.064)
    >>> bound_step(st, False, 30.0, 0.0, 0.01).touching
    False
    """
    if not probe_touching:
        return PassiveBoundState() if st.touching else st
    if not st.touching:
        st = PassiveBoundState(touching=True, start_C=float(finger_C))
    heat = st.heat_J + (float(probe_flux_W) * dt_s if math.isfinite(probe_flux_W) else 0.0)
    elapsed = st.elapsed_s + dt_s
    side, ext, decided = st.side, st.extreme_C, st.decided_J
    if side == 0 and elapsed >= DECIDE_S - 1e-9 and heat != 0.0:
        side, decided = (1 if heat > 0.0 else -1), heat
    elif side != 0 and abs(decided) < FLIP_J and heat * side < -FLIP_J:
        # a side decided on less heat than FLIP_J, and the touch's heat has since run FLIP_J the other way:
        # the other side, its extreme afresh; decided on FLIP_J, it does not turn again
        side, ext, decided = -side, math.nan, heat
    return PassiveBoundState(True, st.start_C, heat, elapsed, side, ext, decided)


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


def held_target(
    st: PassiveBoundState, req_C: float, neutral_C: float, return_C: float = RETURN_C
) -> tuple[float, PassiveBoundState]:
    """:func:`bounded_target`, then no more than ``return_C`` (°C) back from the furthest the bounded target
    has gone towards the object in this touch (see the module docstring). Returns the target (°C) and the
    state with that extreme; both unchanged before the side is decided or for a target that is not finite.

    >>> st = PassiveBoundState(True, 34.0, 0.1, 0.2, 1)     # a colder object
    >>> req, st = held_target(st, 20.0, 32.0)               # the target falls to the object's 20 °C
    >>> req, st.extreme_C
    (20.0, 20.0)
    >>> held_target(st, 29.0, 32.0)[0]                      # the probe's heat brings it back: 1.5 °C of it
    21.5
    >>> held_target(PassiveBoundState(True, 31.0, -0.1, 0.2, -1, 45.0), 40.0, 32.0)[0]   # a hotter object
    43.5
    """
    req = bounded_target(st, req_C, neutral_C)
    if st.side == 0 or not math.isfinite(req):
        return req, st
    ext = st.extreme_C
    if not math.isfinite(ext):
        ext = req
    if st.side > 0:
        ext = min(ext, req)
        return min(req, ext + return_C), replace(st, extreme_C=ext)
    ext = max(ext, req)
    return max(req, ext - return_C), replace(st, extreme_C=ext)


def passive_flux_W(st: PassiveBoundState, flux_W: float) -> float:
    """The probe's flux (W, > 0 into the object) as a passive object exchanges it with a finger: from the
    side's decision on, a colder object only takes heat (flux >= 0) and a hotter one only gives it (<= 0);
    unchanged before the decision or when not finite.

    >>> cold, hot = PassiveBoundState(True, 34.0, 0.1, 0.2, 1), PassiveBoundState(True, 31.0, -0.1, 0.2, -1)
    >>> passive_flux_W(cold, 2.0), passive_flux_W(cold, -0.5)
    (2.0, 0.0)
    >>> passive_flux_W(hot, 1.3), passive_flux_W(hot, -4.0)
    (0.0, -4.0)
    """
    if st.side == 0 or not math.isfinite(flux_W):
        return flux_W
    return max(flux_W, 0.0) if st.side > 0 else min(flux_W, 0.0)
