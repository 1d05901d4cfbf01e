"""Sources of frames for the monitor: a recorded log file (as fast as possible or paced at the
recorded speed) and a live python-can bus."""
from __future__ import annotations

import csv
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
    if p.suffix.lower() == ".csv" and _is_record_csv(p):
        return read_record_csv(p)
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


#: the first columns of the decoded CSV ``telethermo record`` writes (telethermo.monitor.record.CSV_COLUMNS)
RECORD_CSV_HEAD = ("t_s", "cob_id", "kind", "node", "dlc", "data")


def _is_record_csv(p: Path) -> bool:
    try:
        with open(p, newline="", encoding="utf-8") as fh:
            head = next(csv.reader(fh), [])
    except (OSError, UnicodeDecodeError, csv.Error):
        return False
    return tuple(head[:len(RECORD_CSV_HEAD)]) == RECORD_CSV_HEAD


def _csv_message(row: list[str]) -> can.Message:
    """One frame of a record CSV row (t_s, cob_id 0x.., kind, node, dlc, data hex, ...); ValueError."""
    if len(row) < len(RECORD_CSV_HEAD):
        raise ValueError(f"{len(row)} columns, expected at least {len(RECORD_CSV_HEAD)} ({', '.join(RECORD_CSV_HEAD)})")
    t_s, cob, kind, _node, dlc, data = row[:len(RECORD_CSV_HEAD)]
    payload = bytes.fromhex(data)
    cob_id = int(cob, 16)
    if int(dlc) != len(payload):
        raise ValueError(f"dlc {dlc} but {len(payload)} data bytes")
    return can.Message(timestamp=float(t_s), arbitration_id=cob_id, data=payload,
                       is_extended_id=len(cob.removeprefix("0x")) > 3 or cob_id > 0x7FF,
                       is_error_frame=kind == "ERROR_FRAME")


def read_record_csv(p: Path) -> Iterator[can.Message]:
    """The frames of the decoded CSV ``telethermo record`` writes; a damaged row is a ReplayError
    naming its line."""
    def gen() -> Iterator[can.Message]:
        with open(p, newline="", encoding="utf-8") as fh:
            rows = csv.reader(fh)
            next(rows, None)
            for row in rows:
                if not row:
                    continue
                try:
                    yield _csv_message(row)
                except (ValueError, TypeError) as exc:
                    raise ReplayError(f"{p}:{rows.line_num}: damaged row ({exc})") from None
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
