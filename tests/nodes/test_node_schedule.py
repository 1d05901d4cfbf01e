"""The real-time ticker's logic, with an injected clock (no wall-clock assertions)."""
from __future__ import annotations

import pytest

from nodes.schedule import RealtimeTicker


class FakeClock:
    def __init__(self) -> None:
        self.t = 100.0
        self.slept: list[float] = []

    def __call__(self) -> float:
        return self.t

    def sleep(self, dt: float) -> None:
        self.slept.append(dt)
        self.t += dt


def test_ticker_paces_and_counts_late_cycles():
    clock = FakeClock()
    tick = RealtimeTicker(0.010, clock=clock, sleep=clock.sleep)
    assert tick.wait_next() == (False, 0.0)           # first cycle: now
    clock.t += 0.002                                  # work takes 2 ms
    late, lateness = tick.wait_next()
    assert not late and clock.slept[-1] == pytest.approx(0.008)
    clock.t += 0.0125                                 # work overran into the next slot by 2.5 ms
    late, lateness = tick.wait_next()
    assert late and lateness == pytest.approx(0.0025)
    assert tick.stats.late_cycles == 1 and tick.stats.overruns == 0
    clock.t += 0.050                                  # a stall of several periods
    late, lateness = tick.wait_next()
    assert late and tick.stats.overruns == 1
    start = clock.t
    clock.t += 0.001
    assert tick.wait_next()[0] is False               # re-anchored: next due one period after the stall
    assert clock.t == pytest.approx(start + 0.010)
    assert tick.stats.cycles == 5 and tick.stats.late_cycles == 2
