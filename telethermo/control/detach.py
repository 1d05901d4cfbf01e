"""A sensor that has come off the pad (issue 24 item 4): holding the target takes far more current than the
TEM's physics says (trip ``SENSOR_DETACHED``, EMCY 0x5014). Pure functions; the envelope
(:mod:`telethermo.control.safety`) runs them on every sample.

The sensor head (thermocouple and flux sensor) rests on the TEM's pad plate. Off the pad it reads the air:
the controller's current no longer moves what it sees, while the pad itself runs away (hot or cold) under a
skin the envelope can no longer see (measured: a master whose sensor came off during a touch of aluminium
cooled the skin from 27 to 16 °C in 4.5 s, the sensor reading 25.5 °C, no other trip). The TEM's steady heat
balance of the pad plate
(guiatni eq. 1-6, the rig's sign convention: current > 0 heats the pad, Q > 0 leaves the pad into its load)

    Q_load = α·I·(T_p + 273.15) + ½·R·I² + ½·τ·I·(T_p − T_s) + K·(T_s − T_p)

gives the current that holds the pad at T_p with the sink at T_s and the load the flux sensor measures
(:func:`hold_current_A`). A sensor on the pad sees the load (a cold block draws watts, so the holding current
is large and the controller's is too); a sensor off the pad sees none, so the prediction stays near 0 A
while the controller's current sits at its limit.

The check (:func:`detach_excess`): the pad is steady by its sensor (the reading's slope below
``detach_slope_C_per_s``) **and** the measured current differs from the holding current at the sensor's
temperature by more than ``detach_excess_A + detach_rel·|I_hold|``. Steady means the pad's own heat capacity
takes nothing, so the balance must hold whatever touches the pad. Off the pad, the sensor settles in the air
while the controller's current (its integral, a telepresence feed-forward mirroring the peer's flux) does
not match the load the sensor no longer sees. The envelope counts the time this holds with a leaky timer
(up while it holds, down at the same rate while not) and trips when it reaches ``detach_time_s``: a
contact's transient (the current far from steady for a fraction of a second while the pad's heat capacity
charges) or a short saturation does not trip it.

TEM constants: the envelope's ``tem_alpha_V_K``, ``tem_R_ohm``, ``tem_K_W_K``, ``tem_tau_V_K`` (defaults: the
shipped rig's 15 × 15 mm module, derived from its datasheet as sim/tem.py derives them; a node on a simulated
rig takes its rig's own, :func:`tem_limits`, in the offline runner and the node programs alike);
``tem_alpha_V_K`` = 0 turns the check off. The identified capacity model (eq. 13, ``telethermo identify``) is
not used: it is fitted on free-air steady states within ±0.25 A, which fix neither the load term nor the
curvature (the shipped fit's θ2 is negative, the physics' ½·R positive).
"""

from __future__ import annotations

import math
from typing import Any

from telethermo.units import KELVIN


def datasheet_constants(
    Imax_A: float, Vmax_V: float, dTmax_K: float, Th_C: float
) -> tuple[float, float, float]:
    """(α V/K, R Ω, K W/K) of an ideal module from its ratings (the standard derivation sim.tem uses)."""
    Th = Th_C + KELVIN
    return (
        Vmax_V / Th,
        (Th - dTmax_K) * Vmax_V / (Th * Imax_A),
        (Th - dTmax_K) * Vmax_V * Imax_A / (2.0 * Th * dTmax_K),
    )


#: the shipped rig's TEM (sim/data/tem_15x15.toml: Imax 3 A, Vmax 3.75 V, ΔTmax 67 K at 27 °C;
#: Thomson 1.9 mV/K)
SHIPPED_ALPHA_V_K, SHIPPED_R_OHM, SHIPPED_K_W_K = datasheet_constants(3.0, 3.75, 67.0, 27.0)
SHIPPED_TAU_V_K = 1.9e-3


def hold_current_A(
    alpha_V_K: float,
    R_ohm: float,
    K_W_K: float,
    tau_V_K: float,
    *,
    T_pad_C: float,
    T_sink_C: float,
    Q_load_W: float,
    I_limit_A: float,
) -> float:
    """The steady current that holds the pad plate at ``T_pad_C`` with the sink at ``T_sink_C`` and
    ``Q_load_W`` leaving the pad into its load, A, clipped to ±``I_limit_A`` (a load beyond the TEM's
    capacity: the limit on that side; the heat out of the pad is a parabola in I, so heating always has a
    root, cooling may not). NaN if an input is not finite.

    >>> round(hold_current_A(0.0125, 1.0, 0.05, 0.0, T_pad_C=33.0, T_sink_C=25.0, Q_load_W=0.0,
    ...                      I_limit_A=2.4), 4)
    0.1031
    """
    if not all(math.isfinite(v) for v in (T_pad_C, T_sink_C, Q_load_W)):
        return math.nan
    a = 0.5 * R_ohm
    b = alpha_V_K * (T_pad_C + KELVIN) + 0.5 * tau_V_K * (T_pad_C - T_sink_C)
    c = K_W_K * (T_sink_C - T_pad_C) - Q_load_W
    if a <= 0.0:
        i = -c / b
    else:
        disc = b * b - 4.0 * a * c
        if disc < 0.0:  # more heat in than the module can pump away at any current: it cools flat out
            return -I_limit_A
        i = 2.0 * (-c) / (b + math.sqrt(disc))  # the root through 0 A (no cancellation)
    return max(-I_limit_A, min(I_limit_A, i))


#: time constant of the sensor's running average, s: (T - average) / tau is its slope over about a second
AVERAGE_TAU_S = 1.0


def sensor_average(avg_C: float, T_sensor_C: float, dt_s: float) -> float:
    """The sensor's running average, °C (first order, :data:`AVERAGE_TAU_S`); starts at the first finite
    reading."""
    if not math.isfinite(T_sensor_C):
        return avg_C
    if not math.isfinite(avg_C):
        return T_sensor_C
    return avg_C + (T_sensor_C - avg_C) * min(1.0, dt_s / AVERAGE_TAU_S)


def detach_excess(
    limits: Any, *, T_sensor_C: float, T_avg_C: float, current_A: float, T_sink_C: float, Q_W: float
) -> bool:
    """This sample says "sensor off the pad": the pad is steady by its sensor (the sensor's slope, from its
    running average ``T_avg_C``, below ``detach_slope_C_per_s``) and yet the current differs from the one that
    holds the pad at that temperature against the measured load by more than
    ``detach_excess_A + detach_rel·|I_hold|``. At steady state the TEM's balance holds whatever touches the
    pad, so only a sensor that does not see the pad (or a TEM unlike the constants) breaks it.
    ``limits``: a :class:`telethermo.control.safety_limits.SafetyLimits`. False when the check is off or an
    input is missing."""
    if limits.tem_alpha_V_K <= 0.0:
        return False
    if not all(math.isfinite(v) for v in (T_sensor_C, T_avg_C, current_A)):
        return False
    if abs(T_sensor_C - T_avg_C) / AVERAGE_TAU_S > limits.detach_slope_C_per_s:
        return False
    hold = hold_current_A(
        limits.tem_alpha_V_K,
        limits.tem_R_ohm,
        limits.tem_K_W_K,
        limits.tem_tau_V_K,
        T_pad_C=T_sensor_C,
        T_sink_C=T_sink_C,
        Q_load_W=Q_W,
        I_limit_A=limits.I_limit_A,
    )
    if not math.isfinite(hold):
        return False
    margin_A = float(limits.detach_excess_A + limits.detach_rel * abs(hold))
    return abs(current_A - hold) > margin_A


def detach_timer(limits: Any, timer_s: float, excess: bool, dt_s: float) -> tuple[float, bool]:
    """The leaky timer, s (up by ``dt_s`` while ``excess``, down by ``dt_s`` otherwise, never below 0), and
    whether it reached ``detach_time_s`` (trip)."""
    timer_s = timer_s + dt_s if excess else max(0.0, timer_s - dt_s)
    return timer_s, timer_s >= limits.detach_time_s - 1e-9  # (a sum of float steps)


def tem_limits(rig: Any) -> dict[str, float]:
    """The envelope fields of a rig's known TEM, for ``dataclasses.replace(limits, **tem_limits(rig))``: the
    rig's ``tem`` (an I/O rig: its RIG.toml's ``[tem]``, telethermo.iomodule.rigconfig) or its ``params.tem``
    (a simulated rig's), each with ``alpha_V_K``, ``R_ohm``, ``K_W_K``, ``tau_V_K``; {} for a rig that does
    not say (the envelope's own constants stay)."""
    tem = getattr(rig, "tem", None)
    if tem is None:
        tem = getattr(getattr(rig, "params", None), "tem", None)
    if tem is None:
        return {}
    return {
        "tem_alpha_V_K": float(tem.alpha_V_K),
        "tem_R_ohm": float(tem.R_ohm),
        "tem_K_W_K": float(tem.K_W_K),
        "tem_tau_V_K": float(tem.tau_V_K),
    }
