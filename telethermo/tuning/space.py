"""The search space of the tuner: which gains it may change, their bounds, the shipped starting point.

Bounds are in the gains' units (A/°C, A/(°C·s), A/W, A/(W·s)); kQ and kiQ stay at their shipped
values: a screening found every non-zero change worse (docs/tuning.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

from telethermo.control.defaults import GAINS
from telethermo.control.gainsfile import GAIN_FIELDS
from telethermo.control.types import Role


@dataclass(frozen=True)
class GainSpec:
    """One searched gain: ``role`` ("master"/"slave"), CoreParams ``name``, bounds ``lo`` < ``hi`` (> 0)."""

    role: str
    name: str
    lo: float
    hi: float
    stiff: int = 1  # +1: raising it stiffens the loop (PI gains); -1: it damps (the flux-mirror loop)

    def __post_init__(self) -> None:
        if self.role not in ("master", "slave"):
            raise ValueError(f"GainSpec.role: expected 'master' or 'slave', got {self.role!r}")
        if self.name not in GAIN_FIELDS:
            raise ValueError(f"GainSpec.name: expected one of {GAIN_FIELDS}, got {self.name!r}")
        if self.stiff not in (1, -1):
            raise ValueError(f"GainSpec.stiff: expected +1 or -1, got {self.stiff!r}")
        if not (0 < self.lo < self.hi and math.isfinite(self.hi)):
            raise ValueError(f"GainSpec {self.key}: expected 0 < lo < hi, got [{self.lo}, {self.hi}]")

    @property
    def key(self) -> str:
        return f"{self.role}.{self.name}"


#: the default search space: the gains that matter on the guiatni §5.3 scene (docs/tuning.md, screening)
DEFAULT_SPACE: tuple[GainSpec, ...] = (
    GainSpec("master", "kp_A_per_C", 0.1, 5.0),
    GainSpec("master", "ki_A_per_C_s", 0.01, 2.0),
    GainSpec("master", "kpQ_A_per_W", 0.01, 2.0, stiff=-1),
    GainSpec("slave", "kp_A_per_C", 0.05, 5.0),
    GainSpec("slave", "ki_A_per_C_s", 0.01, 2.0),
    GainSpec("slave", "kpQ_A_per_W", 0.005, 1.0, stiff=-1),
)


def default_gains(space: Sequence[GainSpec] = DEFAULT_SPACE) -> dict[str, float]:
    """The shipped defaults (telethermo.control.defaults.GAINS) of the gains in ``space``."""
    return {s.key: float(GAINS[Role(s.role)][s.name]) for s in space}


def clip_gains(gains: dict[str, float], space: Sequence[GainSpec]) -> dict[str, float]:
    """``gains`` with every searched gain clipped to its bounds (other keys untouched)."""
    out = dict(gains)
    for s in space:
        if s.key in out:
            out[s.key] = float(min(max(out[s.key], s.lo), s.hi))
    return out
