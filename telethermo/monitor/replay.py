"""Sources of frames for the monitor: a recorded log file (as fast as possible or paced at the
recorded speed) and a live python-can bus."""
from __future__ import annotations

import time
from pathlib import Path
from typing import Callable, Iterable, Iterator

import can

#: extensions can.LogReader reads
READABLE = (".log", ".asc", ".blf", ".csv", ".trc")


class ReplayError(ValueError):
    """A log file that cannot be replayed (message names the file and what was expected)."""


def read_log(path: str | Path) -> Iterator[can.Message]:
    """Every frame of a python-can log file, in order; ReplayError for a missing or foreign file."""
    p = Path(path)
    if p.suffix.lower() not in READABLE:
        raise ReplayError(f"{p}: cannot replay {p.suffix or 'a file without extension'!r}; expected one of "
                          f"{', '.join(READABLE)}")
    if not p.is_file():
        raise ReplayError(f"{p}: no such log file")
    try:
        reader = can.LogReader(str(p))
    except Exception as exc:   # python-can raises various errors for a foreign file
        raise ReplayError(f"{p}: not a readable {p.suffix} log ({exc})") from exc

    def gen() -> Iterator[can.Message]:
        try:
            yield from reader
        except (ValueError, IndexError, KeyError, OSError) as exc:
            raise ReplayError(f"{p}: damaged log ({exc})") from exc
        finally:
            stop = getattr(reader, "stop", None)
            if stop:
                stop()

    return gen()


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


def paced(messages: Iterable[can.Message], *, speed: float = 1.0,
          clock: Callable[[], float] = time.monotonic, sleep: Callable[[float], None] = time.sleep
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
