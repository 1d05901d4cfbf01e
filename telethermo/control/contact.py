"""Contact detection from the measured heat flux (not from a schedule).

A touch makes the flux through the sensor jump: a finger at ~33 °C on a pad 1 °C away draws
~1 W within the first 10 ms (b_skin·ΔT·S/√(π·t)), while the free pad exchanges a few tens of mW
with the air. But a free pad whose temperature is being ramped also shows a flux: the heat stored
in the sensor above the thermocouple, C_top·dT_sensor/dt (≈ 0.5 W at 5 °C/s). The detector
subtracts that storage term (``c_top_J_per_K``; slope over ``slope_samples``), tracks the remaining
free-pad baseline with a slow average while nothing touches, declares contact when the deviation
exceeds ``on_W`` for ``on_samples`` samples, and release when it stays below ``off_W`` for
``off_time_s``. (A contact heats the sensor from above: its flux and the storage term add, they do
not cancel.) Optionally it ORs in the rig's own
detector flag (IR detector / force switch) or uses the flag alone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum


class ContactSource(str, Enum):
    """Which signals decide contact."""

    FLUX = "flux"  # heat-flux jump only (default)
    FLAG = "flag"  # the rig's detector flag only
    FLUX_OR_FLAG = "flux_or_flag"  # either


@dataclass(frozen=True, slots=True)
class ContactParams:
    """Thresholds of the detector.

    Attributes:
        on_W: |Q - baseline| above which a touch starts, W.
        off_W: |Q - baseline| below which a release is counted, W.
        on_samples: consecutive samples above ``on_W`` needed.
        off_time_s: time below ``off_W`` needed for release, s.
        baseline_tau_s: time constant of the free-pad baseline, s.
        c_top_J_per_K: heat capacity of the sensor between the thermocouple and the contact face,
            J/K (0.42 mm sensor, 15 × 15 mm, ρc ≈ 2 MJ/(m³·K): half of 0.19 J/K); 0 disables.
        slope_samples: samples over which dT_sensor/dt is taken.
        source: :class:`ContactSource`.
    """

    on_W: float = 0.15
    off_W: float = 0.04
    on_samples: int = 1
    off_time_s: float = 0.3
    baseline_tau_s: float = 1.0
    c_top_J_per_K: float = 0.095
    slope_samples: int = 5
    source: ContactSource = ContactSource.FLUX

    def __post_init__(self) -> None:
        if not (math.isfinite(self.on_W) and math.isfinite(self.off_W) and 0 < self.off_W <= self.on_W):
            raise ValueError(
                f"ContactParams.on_W/off_W: expected 0 < off_W <= on_W, got {self.off_W}, {self.on_W}"
            )
        if not (isinstance(self.on_samples, int) and self.on_samples >= 1):
            raise ValueError(f"ContactParams.on_samples: expected an int >= 1, got {self.on_samples!r}")
        if not (isinstance(self.slope_samples, int) and self.slope_samples >= 1):
            raise ValueError(f"ContactParams.slope_samples: expected an int >= 1, got {self.slope_samples!r}")
        if not (math.isfinite(self.c_top_J_per_K) and self.c_top_J_per_K >= 0):
            raise ValueError(
                f"ContactParams.c_top_J_per_K: expected a finite number >= 0, got {self.c_top_J_per_K!r}"
            )
        if not (self.off_time_s >= 0 and self.baseline_tau_s > 0):
            raise ValueError("ContactParams.off_time_s/baseline_tau_s: expected >= 0 and > 0")
        ContactSource(self.source)


@dataclass(frozen=True, slots=True)
class ContactState:
    """Detector memory: decision, free-pad baseline (W), counters."""

    contact: bool = False
    baseline_W: float = 0.0
    above: int = 0
    below_s: float = 0.0
    since_s: float = 0.0  # time since the last change of decision, s
    T_hist: tuple[float, ...] = ()  # last slope_samples + 1 sensor temperatures, °C (newest first)


def contact_step(
    p: ContactParams, st: ContactState, Q_W: float, flag: bool, dt_s: float, T_sensor_C: float = math.nan
) -> ContactState:
    """Advance the detector by one sample (pure). ``T_sensor_C`` feeds the storage correction."""
    if p.source is ContactSource.FLAG:
        c = bool(flag)
        return ContactState(c, st.baseline_W, 0, 0.0, 0.0 if c != st.contact else st.since_s + dt_s)
    if not math.isfinite(Q_W):
        # keep the decision; the envelope trips on the sensor
        return ContactState(st.contact, st.baseline_W, st.above, st.below_s, st.since_s + dt_s, st.T_hist)
    hist = st.T_hist
    storage = 0.0
    if math.isfinite(T_sensor_C):
        hist = (T_sensor_C,) + hist[: p.slope_samples]
        if p.c_top_J_per_K > 0 and len(hist) == p.slope_samples + 1:
            storage = p.c_top_J_per_K * (hist[0] - hist[-1]) / (p.slope_samples * dt_s)
    q = Q_W - storage
    dev = abs(q - st.baseline_W)
    contact, base, above, below = st.contact, st.baseline_W, st.above, st.below_s
    if not contact:
        above = above + 1 if dev > p.on_W else 0
        if above >= p.on_samples:
            contact, below = True, 0.0
        else:
            base += (q - base) * min(1.0, dt_s / p.baseline_tau_s)
    else:
        below = below + dt_s if dev < p.off_W else 0.0
        if below >= p.off_time_s and below > 0.0:
            contact, above = False, 0
    if p.source is ContactSource.FLUX_OR_FLAG and flag:
        contact = True
    since = 0.0 if contact != st.contact else st.since_s + dt_s
    return ContactState(contact, base, above, below, since, hist)
