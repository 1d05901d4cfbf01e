"""The real-time ticker's logic, with an injected clock (no wall-clock assertions)."""

from __future__ import annotations

import pytest

from telethermo.nodes.schedule import RealtimeTicker


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
    assert tick.wait_next() == (False, 0.0)  # first cycle: now
    clock.t += 0.002  # work takes 2 ms
    late, lateness = tick.wait_next()
    assert not late and clock.slept[-1] == pytest.approx(0.008)
    clock.t += 0.0125  # work overran into the next slot by 2.5 ms
    late, lateness = tick.wait_next()
    assert late and lateness == pytest.approx(0.0025)
    assert tick.stats.late_cycles == 1 and tick.stats.overruns == 0
    clock.t += 0.050  # a stall of several periods
    late, lateness = tick.wait_next()
    assert late and tick.stats.overruns == 1
    start = clock.t
    clock.t += 0.001
    assert tick.wait_next()[0] is False  # re-anchored: next due one period after the stall
    assert clock.t == pytest.approx(start + 0.010)
    assert tick.stats.cycles == 5 and tick.stats.late_cycles == 2


class Lines:
    """A logger that keeps what it was told."""

    def __init__(self) -> None:
        self.lines: list[str] = []

    def warning(self, fmt: str, *args) -> None:
        self.lines.append(fmt % args)


def test_late_cycles_are_logged_as_one_summary_per_second_at_most():
    from telethermo.nodes.schedule import LateCycleLog

    clock, out = FakeClock(), Lines()
    late_log = LateCycleLog(out, interval_s=1.0, clock=clock)
    late_log.cycle(0, False, 0.001)
    assert out.lines == []  # nothing late, nothing said
    late_log.cycle(1, True, 0.007)
    assert out.lines == ["cycle 1 late by 7.0 ms"]  # the first one after a quiet second: at once
    for k in range(2, 92):  # 90 late cycles within 0.9 s: no line
        clock.t += 0.01
        late_log.cycle(k, k % 3 == 0, 0.005 + (0.02 if k == 51 else 0.0))
    assert len(out.lines) == 1 and late_log.pending == 30
    clock.t += 0.1  # one second after the first line
    late_log.cycle(92, False, 0.0)
    assert out.lines[1] == "30 late cycles (cycles 3..90, 1.0 s), worst late by 25.0 ms"
    for k in range(93, 1093):  # a late cycle every 10 ms for 10 s: 10 lines, not 1000
        clock.t += 0.01
        late_log.cycle(k, True, 0.006)
    late_log.flush()
    assert 10 <= len(out.lines) - 2 <= 11
    counts = [int(line.split()[0]) for line in out.lines[2:]]
    assert sum(counts) == 1000 and late_log.pending == 0
    late_log.flush()  # nothing pending: nothing more
    assert late_log.lines == len(out.lines)


def test_the_summary_window_follows_the_injected_clock_not_the_cycle_count():
    from telethermo.nodes.schedule import LateCycleLog

    clock, out = FakeClock(), Lines()
    late_log = LateCycleLog(out, interval_s=1.0, clock=clock)
    late_log.cycle(0, True, 0.01)
    late_log.cycle(1, True, 0.02)  # same instant: pending
    assert len(out.lines) == 1
    clock.t += 5.0  # a stall of 5 s, then a late cycle: summary at once
    late_log.cycle(2, True, 0.03)
    assert out.lines[1] == "2 late cycles (cycles 1..2, 5.0 s), worst late by 30.0 ms"


def test_a_node_summarises_late_cycles_per_ten_seconds():
    """Issue 25: a loaded node printed a late-cycle warning every second; the default window is 10 s."""
    from telethermo.nodes.schedule import LateCycleLog

    clock, out = FakeClock(), Lines()
    late_log = LateCycleLog(out, clock=clock)
    for k in range(3000):  # 30 s, every cycle late
        clock.t += 0.01
        late_log.cycle(k, True, 0.008)
    late_log.flush()
    assert 3 <= len(out.lines) <= 5
    assert out.lines[1].startswith("1000 late cycles (cycles 1..1000, 10.0 s), worst late by 8.0 ms")


def test_sync_numbering_unwraps_the_counter_alike_on_every_node():
    from telethermo.nodes.schedule import SyncNumbering

    master, slave = SyncNumbering(240), SyncNumbering(240)
    counters = [(k % 240) + 1 for k in range(1000)]
    got_s = []
    assert [master.on_sync(c) for c in counters] == list(range(1000))
    for k, c in enumerate(counters):
        if not 300 <= k < 539:  # the slave missed 239 SYNCs in a row (fewer than a wrap)
            got_s.append((k, slave.on_sync(c)))
    assert all(n == k for k, n in got_s)
    late = SyncNumbering(240)  # joined at the producer's SYNC 500: right modulo 240
    assert late.on_sync(counters[500]) == 500 % 240
    none = SyncNumbering(0)  # no counter: the SYNCs seen
    assert [none.on_sync(None) for _ in range(3)] == [0, 1, 2]
    guess = SyncNumbering(0)  # 0x1019 unknown: the largest counter seen is the wrap
    assert [guess.on_sync(c) for c in (1, 2, 3, 1, 2)] == [0, 1, 2, 3, 4]


def test_sync_numbering_anchored_on_the_producers_count_continues_its_numbers():
    from telethermo.nodes.schedule import SyncNumbering

    counters = [(k % 240) + 1 for k in range(2000)]
    before = SyncNumbering(240)  # anchored before its first SYNC (a restarted slave)
    before.anchor(1234 - 3)  # the producer's count read 3 SYNCs before SYNC 1234
    assert [before.on_sync(c) for c in counters[1234:1300]] == list(range(1234, 1300))
    after = SyncNumbering(240)  # SYNCs seen while the SDO answer was on its way
    got = [after.on_sync(c) for c in counters[700:705]]
    assert got == [k % 240 for k in range(700, 705)]
    after.anchor(706)  # read a little later than the SYNCs seen: still exact
    assert after.on_sync(counters[705]) == 705
    for hint in (1000 - 119, 1000 + 119):  # off by less than half a wrap either way: exact
        s = SyncNumbering(240)
        s.anchor(hint)
        assert s.on_sync(counters[1000]) == 1000
    first = SyncNumbering(240)  # the producer's first SYNC: count 1, number 0
    first.anchor(0)
    assert first.on_sync(1) == 0
    none = SyncNumbering(0)  # no known wrap: the anchor cannot place it, ignored
    none.anchor(500)
    assert none.on_sync(5) == 4
