"""The safety envelope's state between steps and its summary of one step (:mod:`telethermo.control.safety`
judges; this module holds what it remembers and what it reports)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

from telethermo.control.trips import EMCY_CODES, PEER_TRIPS, Trip, error_register

__all__ = ["SafetyState", "EnvelopeState", "EnvelopeStatus", "summarize"]


class SafetyState(IntEnum):
    """Summary of the envelope's state (the integer is what a node puts in its status object)."""

    OK = 0  # nothing limits the controller
    LIMITING = 1  # a clamp, ramp, guard or the current limit is active this step
    RAMP_TO_NEUTRAL = 2  # peer lost/invalid: setpoint ramping to neutral_C
    CUT = 3  # current cut (latched trip or neutral reached after peer loss)


@dataclass(frozen=True, slots=True)
class EnvelopeState:
    """What the envelope remembers between steps.

    Attributes:
        setpoint_C: the ramped setpoint of the previous step, °C (None before the first step).
        trips: latched trips.
        hot_time_s: continuous time the surface has spent above hot_C, s.
        mismatch_time_s: continuous time the model-vs-sensor mismatch has been exceeded, s.
        detach_time_s: the detached-sensor check's leaky timer, s (:mod:`telethermo.control.detach`);
        sensor_avg_C: the sensor's running average for it, °C (NaN before the first reading).
        neutral_time_s: time since the peer trip started the ramp to neutral, s.
        cut: current cut (latched with the trips that caused it).
        link_fallback: the master's link-loss fallback rendered in this step
            (``EnvelopeInput.link_fallback``), for :func:`telethermo.control.current_guard.slewing`.
        stack_prev_C: the pad stack's band (hi, lo) of the previous step, °C (NaN before the first;
            ``EnvelopeInput.stack_hi_C``).
        stack_rate_C_per_s: its filtered rates (hi, lo), °C/s, for the guard's lead
            (:func:`telethermo.control.current_guard.stack_rates`).
    """

    setpoint_C: float | None = None
    trips: frozenset[Trip] = frozenset()
    hot_time_s: float = 0.0
    mismatch_time_s: float = 0.0
    neutral_time_s: float = 0.0
    cut: bool = False
    detach_time_s: float = 0.0
    sensor_avg_C: float = math.nan
    link_fallback: bool = False
    stack_prev_C: tuple[float, float] = (math.nan, math.nan)
    stack_rate_C_per_s: tuple[float, float] = (0.0, 0.0)


@dataclass(frozen=True, slots=True)
class EnvelopeStatus:
    """What the envelope did this step (for the node's EMCY/status objects and the recordings).

    Attributes:
        state: summary (:class:`SafetyState`).
        trips: active (latched) trips, sorted by name.
        new_trips: trips raised in this step (send one EMCY each, code ``EMCY_CODES[t]``).
        error_register: value for object 0x1001.
        limits_active: names of the limits that acted this step (subset of "setpoint_clamp",
            "ramp", "hot_cap", "guard", "current_limit", "neutral_ramp", "cut").
    """

    state: SafetyState
    trips: tuple[Trip, ...]
    new_trips: tuple[Trip, ...]
    error_register: int
    limits_active: tuple[str, ...]

    @property
    def emcy_codes(self) -> tuple[int, ...]:
        """CiA 301 error codes of the active trips."""
        return tuple(EMCY_CODES[t] for t in self.trips)

    @property
    def new_emcy_codes(self) -> tuple[int, ...]:
        """CiA 301 error codes to send now (one EMCY per trip raised in this step)."""
        return tuple(EMCY_CODES[t] for t in self.new_trips)


def summarize(
    state: EnvelopeState, new_trips: frozenset[Trip], limits_active: tuple[str, ...]
) -> EnvelopeStatus:
    """Build the step's :class:`EnvelopeStatus`."""
    trips = tuple(sorted(state.trips, key=lambda t: t.value))
    if state.cut:
        s = SafetyState.CUT
    elif state.trips & PEER_TRIPS:
        s = SafetyState.RAMP_TO_NEUTRAL
    elif limits_active or state.trips:
        s = SafetyState.LIMITING
    else:
        s = SafetyState.OK
    return EnvelopeStatus(
        state=s,
        trips=trips,
        new_trips=tuple(sorted(new_trips, key=lambda t: t.value)),
        error_register=error_register(state.trips),
        limits_active=limits_active,
    )
