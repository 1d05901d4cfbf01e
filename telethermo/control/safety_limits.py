"""The safety envelope's limits (DESIGN.md §6): :class:`SafetyLimits`, the skin's defaults and the probe's
(:func:`probe_limits`). Data and validation only; :mod:`telethermo.control.safety` applies them."""

from __future__ import annotations

import math
from dataclasses import dataclass

from telethermo.control.detach import SHIPPED_ALPHA_V_K, SHIPPED_K_W_K, SHIPPED_R_OHM, SHIPPED_TAU_V_K

DEFAULT_T_MIN_C = 15.0
DEFAULT_T_MAX_C = 43.0
#: the probe's surface limits, °C (it has no skin: its own hardware's range, so that it follows a 5 °C or a
#: 50 °C object as a finger would; condensation below 0 °C, the module's solder and sensor well above 60 °C)
PROBE_T_MIN_C = 0.0
PROBE_T_MAX_C = 60.0
#: what an envelope protects: the operator's skin (master) or the probe's hardware (slave)
PROTECTS = ("skin", "probe")
#: the trip slew limit, A/s (see :class:`SafetyLimits`; chosen from bench/stress_slew.py's sweep)
DEFAULT_TRIP_SLEW_A_PER_S = 2.0
#: how far the neutral ramp's setpoint may lead the pad surface, °C (see :class:`SafetyLimits`)
DEFAULT_TRIP_LEAD_C = 1.5


@dataclass(frozen=True, slots=True)
class SafetyLimits:
    """Limits of the envelope. Validated on construction (ValueError naming the field).

    Attributes:
        I_max_A: hardware current limit of the TEM drive, A.
        current_fraction: the envelope allows |I| <= current_fraction·I_max_A (<= 0.8 unless research).
        cooling_limit_A: the largest cooling current (I < 0) that still cools more, A: the TEM's
            maximum-cooling current from its identified model (telethermo.control.cooling_limit); beyond
            it the Joule heat wins and more current warms the pad. ``math.inf``: unknown, no extra limit.
        T_min_C, T_max_C: setpoint and surface clamp, °C (within [15, 43] unless research).
        ramp_up_C_per_s, ramp_down_C_per_s: setpoint rate limits, °C/s.
        hot_C: time-at-temperature threshold, °C; hot_time_limit_s: allowed continuous time above, s.
        guard_C: band inside each clamp in which the current may only push the surface back, °C.
        taper_C: below the guard band the current driving outwards is tapered linearly to 0 over
            this band, °C (the plate stores heat: a pad heated at full current overshoots a hard stop).
        guard_lead_s: the guard and the taper see the surface this far ahead, s: while the pad stack (both
            sensor faces) moves towards a clamp the surface counts as ``rate·guard_lead_s`` nearer to it (the
            rate filtered over :data:`~telethermo.control.current_guard.RATE_FILTER_S`), so that the heat
            already on its way from a plate driven hard does not carry the skin past the clamp (0: no lead).
        surface_trip_margin_C: surface beyond a clamp by more than this trips (current cut), °C.
        sink_trip_C: heat-sink trip, °C.
        sensor_min_C, sensor_max_C: plausible thermocouple range, °C; open_tc_C: reading at or
            beyond which the thermocouple counts as open, °C; Q_abs_max_W: plausible |flux|, W.
        mismatch_C, mismatch_time_s: model-vs-sensor mismatch trip, °C and s held.
        neutral_C: where the setpoint ramps on peer loss, °C; neutral_tol_C: how close counts as
            reached before the current is cut, °C; neutral_timeout_s: cut anyway after this long, s.
        peer_T_min_C, peer_T_max_C, peer_Q_abs_max_W: plausible peer values (beyond: PEER_INVALID).
        trip_slew_A_per_s: while a peer trip is latched, the largest change of the current per second, A/s
            (the ramp limit's counterpart for the current; ``math.inf`` turns it off, research only).
        trip_lead_C: while a peer trip ramps the setpoint to neutral, the setpoint leads the credible surface
        by
            at most this, °C (it waits for a lagging pad; ``math.inf`` turns it off, research only).
        tem_alpha_V_K, tem_R_ohm, tem_K_W_K, tem_tau_V_K: the TEM's Seebeck coefficient (V/K), resistance
            (Ω), conductance (W/K) and Thomson coefficient (V/K) for the detached-sensor check
            (:mod:`telethermo.control.detach`; default the shipped 15 × 15 mm module; alpha 0: no check).
        detach_excess_A, detach_rel, detach_slope_C_per_s, detach_time_s: the check trips SENSOR_DETACHED when
            the current differs from the holding current by more than detach_excess_A + detach_rel·|I_hold|
            while the sensor's slope is below detach_slope_C_per_s (°C/s), for detach_time_s s (leaky count).
        research: allow limits wider than the defaults (a deliberate research flag).
        protects: "skin" (the master: the clamps guard a person's skin, [15, 43] °C at the widest, and the
            guard acts on the pad's contact face, the honest bound on the skin) or "probe" (the slave: its
            hardware's range, [0, 60] °C at the widest, and the guard acts on the whole pad stack,
            both faces of the sensor); see :func:`probe_limits`.
    """

    I_max_A: float = 2.0
    current_fraction: float = 0.8
    cooling_limit_A: float = math.inf
    T_min_C: float = DEFAULT_T_MIN_C
    T_max_C: float = DEFAULT_T_MAX_C
    ramp_up_C_per_s: float = 5.0
    ramp_down_C_per_s: float = 5.0
    hot_C: float = 41.0
    hot_time_limit_s: float = 30.0
    guard_C: float = 0.5
    taper_C: float = 2.0
    guard_lead_s: float = 0.03
    surface_trip_margin_C: float = 2.0
    sink_trip_C: float = 55.0
    sensor_min_C: float = -20.0
    sensor_max_C: float = 90.0
    open_tc_C: float = 500.0
    Q_abs_max_W: float = 30.0
    mismatch_C: float = 12.0
    mismatch_time_s: float = 1.0
    neutral_C: float = 32.0
    neutral_tol_C: float = 0.3
    neutral_timeout_s: float = 5.0
    peer_T_min_C: float = -20.0
    peer_T_max_C: float = 90.0
    peer_Q_abs_max_W: float = 30.0
    trip_slew_A_per_s: float = DEFAULT_TRIP_SLEW_A_PER_S
    trip_lead_C: float = DEFAULT_TRIP_LEAD_C
    tem_alpha_V_K: float = SHIPPED_ALPHA_V_K
    tem_R_ohm: float = SHIPPED_R_OHM
    tem_K_W_K: float = SHIPPED_K_W_K
    tem_tau_V_K: float = SHIPPED_TAU_V_K
    detach_excess_A: float = 0.8
    detach_rel: float = 0.5
    detach_slope_C_per_s: float = 0.2
    detach_time_s: float = 3.0
    research: bool = False
    protects: str = "skin"

    def __post_init__(self) -> None:
        if self.protects not in PROTECTS:
            raise ValueError(f"SafetyLimits.protects: expected one of {PROTECTS}, got {self.protects!r}")
        for name in self.__dataclass_fields__:
            if name == "protects":
                continue
            v = getattr(self, name)
            if name in ("trip_slew_A_per_s", "trip_lead_C") and self.research and v == math.inf:
                continue
            if name == "cooling_limit_A" and v == math.inf:
                continue
            if name != "research" and not (isinstance(v, (int, float)) and math.isfinite(v)):
                raise ValueError(f"SafetyLimits.{name}: expected a finite number, got {v!r}")
        positive = (
            "I_max_A",
            "current_fraction",
            "cooling_limit_A",
            "ramp_up_C_per_s",
            "ramp_down_C_per_s",
            "hot_time_limit_s",
            "Q_abs_max_W",
            "mismatch_C",
            "mismatch_time_s",
            "neutral_tol_C",
            "neutral_timeout_s",
            "peer_Q_abs_max_W",
            "trip_slew_A_per_s",
            "trip_lead_C",
            "detach_time_s",
        )
        for name in positive:
            if getattr(self, name) <= 0:
                raise ValueError(f"SafetyLimits.{name}: expected > 0, got {getattr(self, name)!r}")
        for name in (
            "tem_alpha_V_K",
            "tem_R_ohm",
            "tem_K_W_K",
            "detach_excess_A",
            "detach_rel",
            "detach_slope_C_per_s",
            "guard_lead_s",
        ):
            if getattr(self, name) < 0:
                raise ValueError(f"SafetyLimits.{name}: expected >= 0, got {getattr(self, name)!r}")
        if self.guard_C < 0 or self.surface_trip_margin_C < 0 or self.taper_C < 0:
            raise ValueError("SafetyLimits.guard_C/taper_C/surface_trip_margin_C: expected >= 0")
        if not self.T_min_C < self.T_max_C:
            raise ValueError(
                f"SafetyLimits.T_min_C/T_max_C: expected T_min_C < T_max_C, got "
                f"{self.T_min_C} and {self.T_max_C}"
            )
        if not self.T_min_C + 2 * self.guard_C < self.T_max_C:
            raise ValueError("SafetyLimits.guard_C: the two guard bands overlap")
        if not self.T_min_C <= self.neutral_C <= self.T_max_C:
            raise ValueError(
                f"SafetyLimits.neutral_C: expected within [T_min_C, T_max_C], got {self.neutral_C}"
            )
        if not self.sensor_min_C < self.sensor_max_C < self.open_tc_C:
            raise ValueError(
                "SafetyLimits.sensor_min_C/sensor_max_C/open_tc_C: expected min < max < open_tc_C"
            )
        if not self.research:
            if self.current_fraction > 0.8:
                raise ValueError(
                    f"SafetyLimits.current_fraction: expected <= 0.8 (research=False), got "
                    f"{self.current_fraction}"
                )
            lo, hi = self.widest_C
            if self.T_min_C < lo or self.T_max_C > hi:
                raise ValueError(
                    f"SafetyLimits.T_min_C/T_max_C: expected within [{lo}, {hi}] °C for the "
                    f"{self.protects} (narrower only unless research=True), got "
                    f"[{self.T_min_C}, {self.T_max_C}]"
                )
            if self.sink_trip_C > 55.0:
                raise ValueError(
                    f"SafetyLimits.sink_trip_C: expected <= 55 °C (research=False), got {self.sink_trip_C}"
                )
        elif self.current_fraction > 1.0:
            raise ValueError(f"SafetyLimits.current_fraction: expected <= 1, got {self.current_fraction}")

    @property
    def widest_C(self) -> tuple[float, float]:
        """The widest clamps allowed without the research flag, °C: the skin's or the probe's."""
        return (
            (DEFAULT_T_MIN_C, DEFAULT_T_MAX_C) if self.protects == "skin" else (PROBE_T_MIN_C, PROBE_T_MAX_C)
        )

    @property
    def I_limit_A(self) -> float:
        """Largest |current| the envelope lets through, A."""
        return self.current_fraction * self.I_max_A

    @property
    def I_cool_limit_A(self) -> float:
        """Largest cooling |current| (I < 0) the envelope lets through, A: the current limit, or the TEM's
        maximum-cooling current where that is lower."""
        return min(self.I_limit_A, self.cooling_limit_A)


def probe_limits(**overrides: object) -> SafetyLimits:
    """The slave's envelope: it protects the probe's hardware, not skin (DESIGN.md §6). Surface clamps
    [0, 60] °C, no time-at-temperature cap below 58 °C, and the current, sink, plausibility and peer rules of
    the skin's envelope; ``overrides`` win."""
    kw: dict[str, object] = dict(
        protects="probe", T_min_C=PROBE_T_MIN_C, T_max_C=PROBE_T_MAX_C, hot_C=58.0, hot_time_limit_s=600.0
    )
    kw.update(overrides)
    return SafetyLimits(**kw)  # type: ignore[arg-type]


#  the limits an envelope step reports (``EnvelopeStatus.limits_active``), bit i of the node's
# ``limits_active``
#: object (0x2708): a target beyond the clamps saturates there (bit 0) and the operator sees it in ``status``
LIMIT_NAMES = ("setpoint_clamp", "ramp", "hot_cap", "guard", "current_limit", "neutral_ramp", "cut", "slew")


def limits_mask(names: tuple[str, ...] | list[str]) -> int:
    """Bit mask of limit names (unknown names ignored).

    >>> limits_mask(("setpoint_clamp", "guard"))
    9
    """
    return sum(1 << LIMIT_NAMES.index(n) for n in set(names) if n in LIMIT_NAMES)


def limits_from_mask(mask: int) -> list[str]:
    """The names of the bits set in ``mask``.

    >>> limits_from_mask(9)
    ['setpoint_clamp', 'guard']
    """
    return [n for i, n in enumerate(LIMIT_NAMES) if mask >> i & 1]
