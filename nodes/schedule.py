"""When cycles run in real time (DESIGN.md §3): the wall-clock ticker of the SYNC producer,
clock-injectable so that its logic is tested without the wall clock. (Lockstep needs no ticker: the
producer waits for the peer's PDOs, see nodes.runtime.NodeRuntime.run_producer.)

Real time: SYNC k is due at ``t0 + k·period``. A cycle that starts more than ``tolerance_s`` after
its due time is *late* (counted, never hidden); one that missed its whole slot re-anchors the
schedule (an *overrun*), so that a stall does not produce a burst of back-to-back catch-up cycles.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import Callable


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

    def __init__(
        self,
        period_s: float,
        *,
        tolerance_s: float | None = None,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
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


class LateCycleLog:
    """Late cycles in the log as one summary line per ``interval_s`` at most (count, cycle range, worst
    lateness), not one line per cycle: on a loaded machine a line per late cycle made the log itself a load.

    Call :meth:`cycle` once per cycle (cheap when nothing is late) and :meth:`flush` at the end. The first
    late cycle after a quiet second is reported at once; later ones are summed until ``interval_s`` has
    passed since the last line.

    Args:
        logger: where the lines go (``warning``).
        interval_s: at most one line per this many seconds (10 s: a loaded lab PC's terminal is not flooded).
        clock: monotonic clock, s (injectable).
    """

    def __init__(
        self, logger, *, interval_s: float = 10.0, clock: Callable[[], float] = time.monotonic
    ) -> None:
        self.logger = logger
        self.interval_s = interval_s
        self._clock = clock
        self._last_line = -float("inf")
        self.lines = 0
        self._reset()

    def _reset(self) -> None:
        self.pending = 0
        self._first_k = self._last_k = -1
        self._worst_s = 0.0
        self._since = None

    def cycle(self, k: int, late: bool, lateness_s: float) -> None:
        """Cycle ``k`` started ``lateness_s`` after its due time; ``late``: it counts as late."""
        if late:
            if not self.pending:
                self._first_k, self._since = k, self._clock()
            self.pending += 1
            self._last_k = k
            self._worst_s = max(self._worst_s, lateness_s)
        if self.pending and self._clock() - self._last_line >= self.interval_s:
            self._emit()

    def flush(self) -> None:
        """Write what is pending (end of the run)."""
        if self.pending:
            self._emit()

    def _emit(self) -> None:
        now = self._clock()
        if self.pending == 1:
            self.logger.warning("cycle %d late by %.1f ms", self._first_k, self._worst_s * 1e3)
        else:
            self.logger.warning(
                "%d late cycles (cycles %d..%d, %.1f s), worst late by %.1f ms",
                self.pending,
                self._first_k,
                self._last_k,
                now - self._since,
                self._worst_s * 1e3,
            )
        self._last_line = now
        self.lines += 1
        self._reset()


class SyncNumbering:
    """The producer's SYNCs numbered from 0, alike on every node, from the 1-byte SYNC counter
    (1..``overflow``, 0x1019): each node unwraps the counter it sees, so SYNC k has number k on the master and
    on the slave (telethermo.recording.merge joins the two recordings on it).

    Right as long as a node misses fewer than ``overflow`` SYNCs in a row (the node runtime also feeds it
    the SYNC frames its device ignores in STOPPED); the time that passed cannot tell how many wraps were
    missed (the producer itself pauses in lockstep and in STOPPED).
    The first SYNC a node sees is number counter - 1 (right for a node that was there from the producer's
    first SYNC; a node that joins later is right modulo ``overflow``, unless :meth:`anchor` gives it the
    producer's count: a restarted slave reads the master's 0x2713 at start, nodes.sync_anchor). Without a
    counter every SYNC seen counts one.

    Args:
        overflow: the counter's overflow value (0x1019; 0 or None: the largest counter seen so far).
    """

    def __init__(self, overflow: int | None) -> None:
        self.overflow = overflow or 0
        self.number = -1
        self._counter: int | None = None
        self._hint: int | None = None
        self._lock = threading.Lock()

    def anchor(self, producer_number: int) -> None:
        """The producer's number of a SYNC sent about now (its count of SYNCs - 1, read by SDO within a few
        cycles): the numbers this node gives become the ones congruent to the counter modulo ``overflow``
        nearest to it, exact while the read took less than half a wrap (120 SYNCs). Without a known
        ``overflow`` (or no counter) it cannot be placed and is ignored."""
        if self.overflow <= 0:
            return
        with self._lock:
            self._hint = producer_number
            if self._counter is not None:
                self.number = _nearest_congruent(self.number, producer_number, self.overflow)

    def on_sync(self, counter: int | None) -> int:
        """Number of the SYNC that just came with ``counter``."""
        with self._lock:
            last = self._counter
            if counter is None:
                self.number += 1
            elif last is None:
                self.number = counter - 1 if self.number < 0 else self.number + 1
                if self._hint is not None and self.overflow > 0:
                    self.number = _nearest_congruent(self.number, self._hint, self.overflow)
            else:
                wrap = self.overflow or max(counter, last)
                self.number += (counter - last) % wrap or wrap
            self._counter = counter
            return self.number


def _nearest_congruent(x: int, near: int, modulus: int) -> int:
    """The integer >= 0 congruent to ``x`` modulo ``modulus`` nearest to ``near`` (ties: the larger)."""
    y = near + (x - near + modulus // 2) % modulus - modulus // 2
    return y if y >= 0 else y % modulus
