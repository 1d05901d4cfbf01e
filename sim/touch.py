"""What a rig (or the bare finger) touches: body specifications and the contact schedule."""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

from telethermo.sim.bodies import FingerParams


@dataclass(frozen=True)
class BodySpec:
    """Something that can touch a pad.

    Attributes:
        name: scene name of the body ("finger" for the operator's finger).
        kind: "finger" or "slab".
        material: materials-table name (slab).
        thickness_m: slab thickness, m.
        T0_C: initial uniform temperature of a slab, °C (a finger starts at its own steady state in air).
        back: "adiabatic" (insulated back face) or "ambient" (back face loses to ambient air, h_air).
        finger: finger parameters (kind "finger").
    """

    name: str
    kind: str = "slab"
    material: str = ""
    thickness_m: float = 0.02
    T0_C: float = 25.0
    back: str = "adiabatic"
    finger: FingerParams | None = None


@dataclass(frozen=True, slots=True)
class Touch:
    """One contact interval: ``body`` touches from start_s (inclusive) to end_s (exclusive) with force_N."""

    start_s: float
    end_s: float
    body: str
    force_N: float
    render: str | None = None


class Schedule:
    """Sorted, non-overlapping contact intervals; O(log n) lookup of the state at a time."""

    def __init__(self, touches: list[Touch] | tuple[Touch, ...]) -> None:
        self.touches = tuple(sorted(touches, key=lambda t: t.start_s))
        for a, b in zip(self.touches, self.touches[1:]):
            if b.start_s < a.end_s:
                raise ValueError(f"overlapping contacts: {a} and {b}")
        self._starts = [t.start_s for t in self.touches]
        self.events = sorted({e for t in self.touches for e in (t.start_s, t.end_s)})

    def at(self, t_s: float) -> Touch | None:
        """The touch active at t_s (start inclusive, end exclusive), or None."""
        i = bisect.bisect_right(self._starts, t_s) - 1
        if i >= 0 and self.touches[i].start_s <= t_s < self.touches[i].end_s:
            return self.touches[i]
        return None

    def next_event_after(self, t_s: float) -> float:
        """The first make/break time strictly after t_s (inf if none)."""
        i = bisect.bisect_right(self.events, t_s)
        return self.events[i] if i < len(self.events) else math.inf

    def bodies(self) -> set[str]:
        return {t.body for t in self.touches}
