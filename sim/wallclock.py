"""A simulated rig paced by the wall clock: the stand-in for hardware (DESIGN.md §3, "Real time").

A :class:`WallClockRig` wraps a simulated rig of this package (:class:`sim.rig.SimRig`) behind the plain
:class:`telethermo.rig.Rig` protocol, **without** an ``advance`` method: nobody can advance it on request, the
plant evolves with time as a real rig does. On every :meth:`WallClockRig.read` the inner simulation is first
brought up to the clock (the time elapsed since the previous read, the current commanded in between held),
then its sample is returned. The node programs take it as hardware (``--rig``), so it exercises their
real-time path::

    telethermo-master --rig sim.wallclock:pads_in_air_master --bus socketcand://127.0.0.1:PORT/telethermo
    telethermo-slave  --rig sim.wallclock:pads_in_air_slave  --bus socketcand://127.0.0.1:PORT/telethermo

Time. The plant's clock starts at the first :meth:`read` (the inner rig's t = 0; before that a rig at rest
has nothing to simulate). From then on the inner time is the wall time since that first read, minus what
the catch-up cap skipped (see below); the scene's contact schedule runs in the inner rig's own time, so a
touch at 2 s of the scene happens 2 s (of wall time) after the first read.

Holding the current. The current commanded by :meth:`apply_current` is held from the previous read to the
next one (zero-order hold, as the lockstep path holds it for one period): the controller's computation
between a read and its command (a fraction of a millisecond) is neglected, as in lockstep.

Sensor chain. Each read takes one sample of the inner rig's measurement chain (noise, ADC, the 2nd-order
low-pass discretised at the nominal ``period_s``), like a drive that samples when it is read; the steps
between reads are the real ones (jitter included), not the nominal period.

Huge gaps (a stopped process, a suspended machine): one read advances the plant by at most
``max_catch_up_s`` (default 1 s); the rest of the gap is skipped (the plant's clock falls behind the wall
clock by it, once) and counted in :attr:`WallClockStats.capped_catch_ups` and ``skipped_s``.

Factories for ``--rig MODULE:FACTORY`` (no arguments; seeds as the node programs' defaults, master 0,
slave 1): :func:`pads_in_air_master`, :func:`pads_in_air_slave` (scene ``pads_in_air``: both pads in air),
:func:`probe_master`, :func:`probe_slave` (scene ``probe_touches_al_steel_wood``).

This module, like all of sim/, knows nothing of the controller: numpy/scipy via sim, telethermo.rig only.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass
from typing import Callable

from telethermo.rig import RigSample
from telethermo.sim.compile import build_rig
from telethermo.sim.scene import load_scene

DEFAULT_MAX_CATCH_UP_S = 1.0
"""The longest stretch of wall time one read simulates, s (a longer gap is skipped beyond it, and counted)."""

#: default noise seeds of the node programs (nodes.parts.DEFAULT_SEEDS), repeated here:
#: sim/ must not import nodes/
SEEDS = {"master": 0, "slave": 1}


@dataclass
class WallClockStats:
    """What a :class:`WallClockRig` counted.

    Attributes:
        reads: calls of read().
        advances: reads that advanced the plant (a read with no time elapsed does not).
        capped_catch_ups: reads whose gap exceeded ``max_catch_up_s`` (only that much was simulated).
        skipped_s: wall time not simulated because of the cap, s.
        max_gap_s: longest gap between two reads, s.
        simulated_s: plant time simulated, s (= the inner rig's time).
    """

    reads: int = 0
    advances: int = 0
    capped_catch_ups: int = 0
    skipped_s: float = 0.0
    max_gap_s: float = 0.0
    simulated_s: float = 0.0


class WallClockRig:
    """A simulated rig that runs in real time: a ``telethermo.rig.Rig`` with no ``advance``.

    Args:
        inner: the simulated rig (``sim.build_rig(...)``; anything with ``advance(dt_s)``, ``read()``,
            ``apply_current(I)``, ``period_s``, ``I_max_A``).
        clock: monotonic clock, s (injectable; default ``time.monotonic``).
        max_catch_up_s: the most one read simulates, s (default 1 s); a longer gap is capped and counted.

    Attributes:
        period_s: the control period the inner rig was configured for, s.
        I_max_A: the TEM drive's current limit, A.
        stats: :class:`WallClockStats`.
    """

    def __init__(
        self,
        inner,
        *,
        clock: Callable[[], float] = time.monotonic,
        max_catch_up_s: float = DEFAULT_MAX_CATCH_UP_S,
    ) -> None:
        if not callable(getattr(inner, "advance", None)):
            raise TypeError(
                f"WallClockRig: the inner rig must be a simulated rig (with advance), got {inner!r}"
            )
        if not (max_catch_up_s > 0 and math.isfinite(max_catch_up_s)):
            raise ValueError(
                f"WallClockRig: max_catch_up_s must be a finite time > 0 s, got {max_catch_up_s!r}"
            )
        self._inner = inner
        self._clock = clock
        self.max_catch_up_s = float(max_catch_up_s)
        self.period_s = float(inner.period_s)
        self.I_max_A = float(inner.I_max_A)
        self.stats = WallClockStats()
        self._last_wall: float | None = None
        self._lock = threading.Lock()  # a node may cut the current from another thread while a cycle reads

    @property
    def inner(self):
        """The wrapped simulated rig (for tests and truth; advancing it by hand defeats the wall clock)."""
        return self._inner

    @property
    def started(self) -> bool:
        """True once the plant's clock runs (after the first read)."""
        return self._last_wall is not None

    def truth(self):
        """The inner rig's ground truth at its present time (not brought up to the clock: no side effect)."""
        return self._inner.truth()

    # ---- rig interface -------------------------------------------------------------------------------
    def read(self) -> RigSample:
        """Bring the plant up to the clock (the current held since the last read), then sample it."""
        with self._lock:
            now = self._clock()
            s = self.stats
            s.reads += 1
            last = self._last_wall
            self._last_wall = now
            if last is not None:
                gap = now - last
                if gap > s.max_gap_s:
                    s.max_gap_s = gap
                if gap > 0.0:
                    dt = gap
                    if gap > self.max_catch_up_s:
                        dt = self.max_catch_up_s
                        s.capped_catch_ups += 1
                        s.skipped_s += gap - dt
                    self._inner.advance(dt)
                    s.advances += 1
                    s.simulated_s += dt
            return self._inner.read()

    def apply_current(self, current_A: float) -> None:
        """Command the drive current, A: held from now on (the plant sees it over the time to the next
        read)."""
        with self._lock:
            self._inner.apply_current(current_A)

    def __repr__(self) -> str:
        return (
            f"WallClockRig({getattr(self._inner, 'name', type(self._inner).__name__)!r}, "
            f"period_s={self.period_s}, t_s={self.stats.simulated_s:.3f})"
        )


def wall_clock_rig(scene: str, role: str, seed: int | None = None, **kw) -> WallClockRig:
    """The ``role`` rig ("master"/"slave") of ``scene`` (a shipped scene's name or a TOML path) in real time;
    ``seed`` defaults to the node programs' (master 0, slave 1); ``kw`` go to :class:`WallClockRig`."""
    if role not in SEEDS:
        raise ValueError(f"wall_clock_rig: role must be 'master' or 'slave', got {role!r}")
    inner = build_rig(load_scene(scene), role, seed=SEEDS[role] if seed is None else seed)
    return WallClockRig(inner, **kw)


def pads_in_air_master() -> WallClockRig:
    """Scene pads_in_air, master rig (pad in air), seed 0, paced by the wall clock."""
    return wall_clock_rig("pads_in_air", "master")


def pads_in_air_slave() -> WallClockRig:
    """Scene pads_in_air, slave rig (probe in air), seed 1, paced by the wall clock."""
    return wall_clock_rig("pads_in_air", "slave")


def probe_master() -> WallClockRig:
    """Scene probe_touches_al_steel_wood, master rig (the finger on the display from t = 0), seed 0."""
    return wall_clock_rig("probe_touches_al_steel_wood", "master")


def probe_slave() -> WallClockRig:
    """Scene probe_touches_al_steel_wood, slave rig (touches aluminium, steel, wood), seed 1."""
    return wall_clock_rig("probe_touches_al_steel_wood", "slave")
