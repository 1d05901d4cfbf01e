"""When cycles run: the lockstep gate of the SYNC producer and the real-time ticker (DESIGN.md §3).

Both are small and clock-injectable so that their logic is tested without the wall clock.

Lockstep: the SYNC producer sends SYNC k+1 only after every node's cycle-k TPDO arrived (its own is
known locally: a node never receives its own frames). A peer that does not answer within
``wait_s`` does not stall the producer for ever: the cycle goes ahead without it (counted), so the
producer's safety envelope keeps running and can ramp to neutral.

Real time: SYNC k is due at ``t0 + k·period``. A cycle that starts more than ``tolerance_s`` after
its due time is *late* (counted, never hidden); one that missed its whole slot re-anchors the
schedule (an *overrun*), so that a stall does not produce a burst of back-to-back catch-up cycles.
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import Callable, Iterable


class LockstepGate:
    """Tracks which nodes completed the current cycle; thread-safe (PDO callbacks arrive on the
    bus's receive thread while the producer waits in its own)."""

    def __init__(self, peer_ids: Iterable[int]) -> None:
        self._peers = frozenset(peer_ids)
        self._cond = threading.Condition()
        self._cycle = -1
        self._own_done = False
        self._done: set[int] = set()
        self.timeouts = 0
        """Cycles that went ahead without every peer's PDO."""

    @property
    def peer_ids(self) -> frozenset[int]:
        return self._peers

    def begin(self, cycle: int) -> None:
        """SYNC ``cycle`` is about to be sent: nothing of it is done yet."""
        with self._cond:
            self._cycle = cycle
            self._own_done = False
            self._done.clear()

    def own_done(self) -> None:
        """This node's cycle is complete (its TPDO is sent)."""
        with self._cond:
            self._own_done = True
            self._cond.notify_all()

    def peer_done(self, node_id: int) -> None:
        """``node_id``'s TPDO of the current cycle arrived (the first one after the SYNC)."""
        with self._cond:
            if node_id in self._peers:
                self._done.add(node_id)
                self._cond.notify_all()

    def complete(self) -> bool:
        with self._cond:
            return self._own_done and self._done >= self._peers

    def missing(self, alive: Iterable[int] | None = None) -> set[int]:
        """Peers whose PDO of this cycle has not arrived (restricted to ``alive`` if given)."""
        with self._cond:
            waiting = set(self._peers - self._done)
        return waiting if alive is None else waiting & set(alive)

    def wait(self, timeout_s: float, *, wait_for: Iterable[int] | None = None) -> bool:
        """Block until our own cycle and the PDOs of ``wait_for`` (default: every peer) are in, or
        ``timeout_s`` passed. Returns True if complete; a timeout is counted in :attr:`timeouts`."""
        needed = self._peers if wait_for is None else frozenset(wait_for) & self._peers
        with self._cond:
            ok = self._cond.wait_for(lambda: self._own_done and self._done >= needed, timeout=timeout_s)
            if not ok:
                self.timeouts += 1
            return ok


@dataclass
class TickerStats:
    """What a :class:`RealtimeTicker` counted."""

    cycles: int = 0
    late_cycles: int = 0
    overruns: int = 0
    max_lateness_s: float = 0.0
    lateness_s: list = field(default_factory=list)
    """Start lateness of every cycle, s (the first ``max_samples``)."""
    max_samples: int = 1_000_000


class RealtimeTicker:
    """Wall-clock pacing: :meth:`wait_next` sleeps until the next cycle is due and says whether it
    is late.

    Args:
        period_s: cycle period, s.
        tolerance_s: lateness still counted on time, s (default: a tenth of the period).
        clock: monotonic clock, s (injectable).
        sleep: sleep function, s (injectable).
    """

    def __init__(self, period_s: float, *, tolerance_s: float | None = None,
                 clock: Callable[[], float] = time.monotonic, sleep: Callable[[float], None] = time.sleep) -> None:
        if not period_s > 0:
            raise ValueError(f"period_s {period_s}: expected > 0 s")
        self.period_s = period_s
        self.tolerance_s = period_s / 10 if tolerance_s is None else tolerance_s
        self._clock = clock
        self._sleep = sleep
        self._due: float | None = None
        self.stats = TickerStats()

    def wait_next(self) -> tuple[bool, float]:
        """Sleep until the next due time; return (late, lateness_s) of the cycle that starts now."""
        now = self._clock()
        if self._due is None:
            self._due = now
        elif now < self._due:
            self._sleep(self._due - now)
            now = self._clock()
        lateness = max(0.0, now - self._due)
        late = lateness > self.tolerance_s
        s = self.stats
        s.cycles += 1
        if len(s.lateness_s) < s.max_samples:
            s.lateness_s.append(lateness)
        s.max_lateness_s = max(s.max_lateness_s, lateness)
        if late:
            s.late_cycles += 1
        if lateness >= self.period_s:
            s.overruns += 1
            self._due = now + self.period_s  # re-anchor: no burst of catch-up cycles
        else:
            self._due += self.period_s
        return late, lateness
