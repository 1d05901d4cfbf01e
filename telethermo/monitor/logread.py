"""Read a recorded bus log, frame by frame, and say exactly where and how a damaged one is damaged.

python-can's readers (:class:`can.LogReader`) let a damaged file through as whatever the parser met:
``zlib.error`` from a corrupted BLF container, "not enough values to unpack" from a bad candump line
(no line number), and nothing at all for a BLF cut short (its frames end early, silently). Here every
damage is a :class:`ReplayError` of one line: the file, where (the line of a text log; the byte of a
BLF), what was read before the damage, and what was expected. A BLF is also checked against its own
header at the end: the size the writer recorded when it closed the file, and no half object left over.

Also reads the decoded CSV ``telethermo record`` writes beside its log (:func:`read_record_csv`).
"""

from __future__ import annotations

import csv
import os
import struct
import zlib
from pathlib import Path
from typing import Iterator

import can
from can.io.blf import BLFParseError, FILE_HEADER_SIZE

#: extensions read here (python-can's formats and the decoded CSV of ``telethermo record``)
READABLE = (".log", ".asc", ".blf", ".csv", ".trc")
#: python-can's reader per text format and what one line of it looks like
TEXT_READERS = {
    ".log": (
        can.CanutilsLogReader,
        "a candump -L line '(TIME) CHANNEL ID#DATA', e.g. '(1.000000) can0 181#00ff'",
    ),
    ".asc": (can.ASCReader, "a Vector ASC line, e.g. '1.000000 1 181 Rx d 2 00 FF'"),
    ".trc": (can.TRCReader, "a PEAK trace line, e.g. '1 1000.000 DT 0181 Rx 2 00 FF'"),
    ".csv": (can.CSVReader, "a python-can CSV row 'timestamp,arbitration_id,extended,remote,error,dlc,data'"),
}
#: the first columns of the decoded CSV ``telethermo record`` writes (telethermo.monitor.record.CSV_COLUMNS)
RECORD_CSV_HEAD = ("t_s", "cob_id", "kind", "node", "dlc", "data")
_BLF_EXPECTED = "expected a Vector BLF file as its writer closed it"


class ReplayError(ValueError):
    """A log file that cannot be replayed (message names the file and what was expected)."""


class _CountedLines:
    """A text file whose lines are counted as a reader takes them (iteration and ``readline``)."""

    def __init__(self, path: Path) -> None:
        self._fh = open(path, encoding="utf-8", errors="strict", newline=None)
        self.line = 0

    def __iter__(self) -> "_CountedLines":
        return self

    def __next__(self) -> str:
        text = next(self._fh)
        self.line += 1
        return text

    def readline(self, *args) -> str:
        text = self._fh.readline(*args)
        self.line += bool(text)
        return text

    def close(self) -> None:
        self._fh.close()

    def __getattr__(self, name: str):
        return getattr(self._fh, name)


def _what_was_read(n: int, first: float | None, last: float | None) -> str:
    """What a reader got before the damage: the frames and the recorded time they span, s."""
    if n == 0:
        return "no frame before it"
    return f"{n} frame{'s' if n != 1 else ''} ({last - first:.3f} s of recording) read before it"


def _name(exc: BaseException) -> str:
    """``zlib.error: ...``, ``ValueError: ...``: the exception's type as Python names it, and its text."""
    cls = type(exc)
    kind = cls.__name__ if cls.__module__ == "builtins" else f"{cls.__module__}.{cls.__name__}"
    return f"{kind}: {exc}" if str(exc) else kind


def read_log(path: str | Path) -> Iterator[can.Message]:
    """Every frame of a log file, in order. ReplayError (one line) for a missing or foreign file at once,
    and from the iterator for a damage found while reading: a text log's line, a BLF's byte."""
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in READABLE:
        raise ReplayError(
            f"{p}: cannot replay {p.suffix or 'a file without extension'!r}; expected one of "
            f"{', '.join(READABLE)}"
        )
    if not p.is_file():
        raise ReplayError(f"{p}: no such log file")
    if suffix == ".csv" and is_record_csv(p):
        return read_record_csv(p)
    if suffix == ".blf":
        return _read_blf(p)
    return _read_text(p, suffix)


def _read_text(p: Path, suffix: str) -> Iterator[can.Message]:
    cls, expected = TEXT_READERS[suffix]
    fh = _CountedLines(p)
    try:
        reader = cls(fh)
    except Exception as exc:  # a reader reads the header in its constructor (ASC, TRC)
        fh.close()
        raise ReplayError(
            f"{p}:{fh.line}: not a readable {suffix} log ({exc}); expected {expected}"
        ) from None

    def gen() -> Iterator[can.Message]:
        n, first, last = 0, None, None
        try:
            for msg in reader:
                n, last = n + 1, msg.timestamp
                first = msg.timestamp if first is None else first
                yield msg
        except (ValueError, IndexError, KeyError, TypeError, AttributeError, OSError) as exc:
            raise ReplayError(
                f"{p}:{fh.line}: damaged line ({_name(exc)}), "
                f"{_what_was_read(n, first, last)}; "
                f"expected {expected}"
            ) from None
        finally:
            fh.close()

    return gen()


def _read_blf(p: Path) -> Iterator[can.Message]:
    size = p.stat().st_size
    try:
        reader = can.BLFReader(str(p))
    except (BLFParseError, struct.error, OSError) as exc:
        raise ReplayError(
            f"{p}: not a BLF log ({exc or 'no LOGG signature'}, {size} bytes); {_BLF_EXPECTED}"
        ) from None
    promised = reader.file_size

    def gen() -> Iterator[can.Message]:
        n, first, last = 0, None, None
        try:
            for msg in reader:
                n, last = n + 1, msg.timestamp
                first = msg.timestamp if first is None else first
                yield msg
        except (zlib.error, struct.error, BLFParseError, ValueError, OSError) as exc:
            at = reader.file.tell() if not reader.file.closed else size
            raise ReplayError(
                f"{p}: damaged BLF at byte {at} of {size} "
                f"({_name(exc)}), {_what_was_read(n, first, last)}; "
                f"{_BLF_EXPECTED}"
            ) from None
        finally:
            reader.stop()
        left = len(reader._tail)  # bytes of an object that never ended (python-can keeps them, says nothing)
        if promised > FILE_HEADER_SIZE and size < promised:
            raise ReplayError(
                f"{p}: truncated BLF: {size} of the {promised} bytes its header records, "
                f"{_what_was_read(n, first, last)}; {_BLF_EXPECTED}"
            )
        if left:
            raise ReplayError(
                f"{p}: truncated BLF: the last object is cut after {left} bytes, "
                f"{_what_was_read(n, first, last)}; {_BLF_EXPECTED}"
            )
        if promised <= FILE_HEADER_SIZE and size > FILE_HEADER_SIZE:
            raise ReplayError(
                f"{p}: unfinished BLF: its header was never completed (the writer did not "
                f"close it), {_what_was_read(n, first, last)}; {_BLF_EXPECTED}"
            )

    return gen()


def is_record_csv(p: Path) -> bool:
    """Whether ``p`` is the decoded CSV ``telethermo record`` writes (by its header)."""
    try:
        with open(p, newline="", encoding="utf-8") as fh:
            head = next(csv.reader(fh), [])
    except (OSError, UnicodeDecodeError, csv.Error):
        return False
    return tuple(head[: len(RECORD_CSV_HEAD)]) == RECORD_CSV_HEAD


def _csv_message(row: list[str]) -> can.Message:
    """One frame of a record CSV row (t_s, cob_id 0x.., kind, node, dlc, data hex, ...); ValueError."""
    if len(row) < len(RECORD_CSV_HEAD):
        raise ValueError(
            f"{len(row)} columns, expected at least {len(RECORD_CSV_HEAD)} ({', '.join(RECORD_CSV_HEAD)})"
        )
    t_s, cob, kind, _node, dlc, data = row[: len(RECORD_CSV_HEAD)]
    payload = bytes.fromhex(data)
    cob_id = int(cob, 16)
    if int(dlc) != len(payload):
        raise ValueError(f"dlc {dlc} but {len(payload)} data bytes")
    return can.Message(
        timestamp=float(t_s),
        arbitration_id=cob_id,
        data=payload,
        is_extended_id=len(cob.removeprefix("0x")) > 3 or cob_id > 0x7FF,
        is_error_frame=kind == "ERROR_FRAME",
    )


def read_record_csv(p: str | os.PathLike) -> Iterator[can.Message]:
    """The frames of the decoded CSV ``telethermo record`` writes; a damaged row is a ReplayError
    naming its line."""
    p = Path(p)

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
