"""Sources of frames for the monitor: a recorded log file (read by :mod:`.logread`, as fast as possible
or paced at the recorded speed) and a live python-can bus."""

from __future__ import annotations

import time
from typing import Callable, Iterable, Iterator

import can

from .logread import READABLE, ReplayError, read_log, read_record_csv  # noqa: F401  (re-exported)


class Pacer:
    """When each recorded frame is due at ``speed`` times the recorded pace (speed <= 0: at once).

    Anchored on the first frame, so delays do not accumulate; :meth:`shift` moves the anchor (a pause).
    """

    def __init__(self, speed: float = 1.0, clock: Callable[[], float] = time.monotonic) -> None:
        self.speed, self.clock = speed, clock
        self._t0_rec: float | None = None
        self._t0_wall = 0.0

    def wait_s(self, msg: can.Message) -> float:
        """Seconds to wait before ``msg`` is due (<= 0: now)."""
        if self.speed <= 0:
            return 0.0
        if self._t0_rec is None:
            self._t0_rec, self._t0_wall = msg.timestamp, self.clock()
            return 0.0
        return self._t0_wall + (msg.timestamp - self._t0_rec) / self.speed - self.clock()

    def shift(self, dt_s: float) -> None:
        self._t0_wall += dt_s


def paced(
    messages: Iterable[can.Message],
    *,
    speed: float = 1.0,
    clock: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], None] = time.sleep,
) -> Iterator[can.Message]:
    """Yield ``messages`` no sooner than their recorded spacing divided by ``speed`` (<= 0: at once)."""
    pacer = Pacer(speed, clock)
    for msg in messages:
        delay = pacer.wait_s(msg)
        if delay > 0:
            sleep(delay)
        yield msg


def live(bus: can.BusABC, *, poll_s: float = 0.1) -> Iterator[can.Message | None]:
    """Frames of a live bus; None when ``poll_s`` passed without one (time to refresh the view)."""
    while True:
        yield bus.recv(poll_s)
