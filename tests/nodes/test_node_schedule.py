"""Lockstep gate and real-time ticker logic, with an injected clock (no wall-clock assertions)."""
from __future__ import annotations

import threading

import pytest

from nodes.schedule import LockstepGate, RealtimeTicker


class FakeClock:
    def __init__(self) -> None:
        self.t = 100.0
        self.slept: list[float] = []

    def __call__(self) -> float:
        return self.t

    def sleep(self, dt: float) -> None:
        self.slept.append(dt)
        self.t += dt


def test_gate_needs_own_and_every_peer():
    gate = LockstepGate([2, 3])
    gate.begin(0)
    assert not gate.complete()
    gate.own_done()
    gate.peer_done(2)
    assert not gate.complete() and gate.missing() == {3}
    gate.peer_done(9)  # not a peer: ignored
    assert not gate.complete()
    gate.peer_done(3)
    assert gate.complete()
    gate.begin(1)
    assert not gate.complete() and gate.missing() == {2, 3}


def test_gate_wait_is_released_by_another_thread_and_counts_timeouts():
    gate = LockstepGate([2])
    gate.begin(0)
    gate.own_done()
    t = threading.Thread(target=gate.peer_done, args=(2,))
    t.start()
    assert gate.wait(10.0)
    t.join()
    gate.begin(1)
    gate.own_done()
    assert not gate.wait(0.01)
    assert gate.timeouts == 1
    # a lost peer is not waited for
    assert gate.wait(0.01, wait_for=[])
    assert gate.timeouts == 1


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
