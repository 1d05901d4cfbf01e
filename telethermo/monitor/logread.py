"""Read a recorded bus log, frame by frame, and say exactly where and how a damaged one is damaged.

python-can's readers (:class:`can.LogReader`) let a damaged file through as whatever the parser met:
``zlib.error`` from a corrupted BLF container, "not enough values to unpack" from a bad candump line
(no line number), and nothing at all for a BLF cut short (its frames end early, silently). Here every
damage is a :class:`ReplayError` of one line: the file, where (the line of a text log; the byte of a
BLF), what was read before the damage, and what was expected. A BLF is also checked against its own
header at the end: the size the writer recorded when it closed the file, and no half object left over.

A text log is also checked line by line as python-can takes it, since its ASC and TRC readers step over
what they cannot read (a garbage line, a frame line too short: at most a warning of the ``can.io.trc``
logger) and every reader takes a last line cut mid-way as a frame with fewer bytes: each line a reader
passes without a frame must be one the format has besides frames (a comment, a header, an event), a
warning of python-can's reader is the damage of the line it was read at (and is not printed), and a
last line without its end of line must hold a whole frame. Lines are decoded one by one, so that a
byte that is not UTF-8 is named by its own line.

Also reads the decoded CSV ``telethermo record`` writes beside its log (:func:`read_record_csv`).
"""

from __future__ import annotations

import csv
import json
import logging
import os
import re
import struct
import zlib
from base64 import b64encode
from pathlib import Path
from typing import Callable, Iterator

import can
from can.io.asc import ASC_MESSAGE_REGEX
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
#: the lines a reader may pass without a frame, per format: blank lines; ASC header, comment, trigger
#: block and timestamped event lines (a frame line among them is a frame python-can did not read); TRC
#: comments and numbered records of a type python-can skips; the header row of python-can's CSV
_NON_FRAME = {
    ".log": re.compile(r"\s*$"),
    ".asc": re.compile(
        r"\s*($|//|(date|base|begin\s+triggerblock|end\s+triggerblock|(no\s+)?internal\s+events)\b"
        r"|\d+\.\d+\s)",
        re.IGNORECASE,
    ),
    ".trc": re.compile(r"\s*($|;|\d+\)?\s+\d+(\.\d+)?\s)"),
    ".csv": re.compile(r"\s*($|timestamp,arbitration_id,)"),
}
_FRAME_LINE = {".asc": ASC_MESSAGE_REGEX}
#: a last line that may lack its end of line (the format's last words, not a record cut short)
_CLOSING = re.compile(r"\s*($|//|;|end\s+triggerblock\s*$)", re.IGNORECASE)
#: a frame's data as the format writes it: a last line without its end of line must show all of it
_DATA_TEXT: dict[str, Callable[[bytes], str]] = {
    ".log": lambda d: d.hex(),
    ".asc": lambda d: d.hex(" "),
    ".trc": lambda d: d.hex(" "),
    ".csv": lambda d: b64encode(d).decode("ascii"),
}
#: python-can's loggers that report a line their reader stepped over (as a warning)
_READER_LOGGERS = ("can.io.asc", "can.io.trc")
#: the first columns of the decoded CSV ``telethermo record`` writes (telethermo.monitor.record.CSV_COLUMNS)
RECORD_CSV_HEAD = ("t_s", "cob_id", "kind", "node", "dlc", "data")
_BLF_EXPECTED = "expected a Vector BLF file as its writer closed it"


class ReplayError(ValueError):
    """A log file that cannot be replayed (message names the file and what was expected)."""


class _CountedLines:
    """A text file whose lines are counted as a reader takes them (iteration and ``readline``), each
    decoded on its own (a UnicodeDecodeError is raised at its line) and kept until :meth:`take`."""

    def __init__(self, path: Path) -> None:
        self._fh = open(path, "rb")
        self.line, self.last = 0, ""  # the number and text of the last line taken
        self._taken: list[tuple[int, str]] = []

    def __iter__(self) -> "_CountedLines":
        return self

    def __next__(self) -> str:
        text = self.readline()
        if not text:
            raise StopIteration
        return text

    def readline(self, *args) -> str:
        raw = self._fh.readline(*args)
        if not raw:
            return ""
        self.line += 1
        text = raw.decode("utf-8")
        if text.endswith("\r\n"):
            text = text[:-2] + "\n"
        self._taken.append((self.line, text))
        self.last = text
        return text

    def take(self) -> list[tuple[int, str]]:
        """The (number, text) of the lines taken since the last call."""
        taken, self._taken = self._taken, []
        return taken

    def close(self) -> None:
        self._fh.close()

    def __getattr__(self, name: str):
        return getattr(self._fh, name)


class _ReaderWarnings(logging.Filter):
    """Keeps (line, text) of each warning python-can's reader logs, instead of printing it."""

    def __init__(self, fh: _CountedLines) -> None:
        super().__init__()
        self.fh = fh
        self.found: list[tuple[int, str]] = []

    def filter(self, record: logging.LogRecord) -> bool:
        if record.levelno < logging.WARNING:
            return True
        if not _CLOSING.match(self.fh.last):  # not TRCReader parsing the blank or comment line a header
            self.found.append((self.fh.line, record.getMessage()))  # ended on (an empty file, no frame)
        return False

    def __enter__(self) -> "_ReaderWarnings":
        for name in _READER_LOGGERS:
            logging.getLogger(name).addFilter(self)
        return self

    def __exit__(self, *exc) -> None:
        for name in _READER_LOGGERS:
            logging.getLogger(name).removeFilter(self)


def _quoted(text: str, limit: int = 40) -> str:
    text = text.strip()
    return repr(text if len(text) <= limit else text[:limit] + "...")


def _whole_frame(suffix: str, msg: can.Message, text: str) -> bool:
    """Whether a line holds all of ``msg`` as written (its data bytes as many as its DLC, each whole)."""
    if suffix == ".log":  # candump's DLC is its data's length: a line cut between two bytes reads whole
        return False
    if msg.is_remote_frame or msg.is_error_frame:
        return True
    if len(msg.data) != msg.dlc:
        return False
    shown = _DATA_TEXT[suffix](bytes(msg.data))
    line = text if suffix == ".csv" else " ".join(text.lower().split())
    return shown in line


def _line_damage(
    suffix: str, taken: list[tuple[int, str]], msg: can.Message | None
) -> tuple[int, str] | None:
    """(line, why) of the first damage among the lines a reader took for ``msg`` (its own line last) or,
    with ``msg`` None, before it ended; None if there is none."""
    skipped = taken[:-1] if msg is not None else taken
    frame_line = _FRAME_LINE.get(suffix)
    for number, text in skipped:
        if not text.endswith("\n") and not _CLOSING.match(text):
            return number, f"truncated line (the file ends mid-line: {_quoted(text)})"
        if not _NON_FRAME[suffix].match(text) or (frame_line and frame_line.match(text.strip())):
            return number, f"damaged line (neither a frame nor a known {suffix} line: {_quoted(text)})"
    if msg is not None:
        number, text = taken[-1]
        if not text.endswith("\n") and not _whole_frame(suffix, msg, text):
            return number, f"truncated line (the file ends mid-frame: {_quoted(text)})"
    return None


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
        frames, warnings = iter(reader), _ReaderWarnings(fh)

        def damage(number: int, why: str) -> ReplayError:
            return ReplayError(f"{p}:{number}: {why}, {_what_was_read(n, first, last)}; expected {expected}")

        try:
            while True:
                with warnings:
                    msg = next(frames, None)
                if warnings.found:
                    number, said = warnings.found[0]
                    raise damage(number, f"damaged line (python-can: {said})")
                found = _line_damage(suffix, fh.take(), msg)
                if found:
                    raise damage(*found)
                if msg is None:
                    return
                n, last = n + 1, msg.timestamp
                first = msg.timestamp if first is None else first
                yield msg
        except ReplayError:
            raise
        except (ValueError, IndexError, KeyError, TypeError, AttributeError, OSError) as exc:
            if fh.last and not fh.last.endswith("\n"):  # what python-can made of a line cut short
                raise damage(
                    fh.line, f"truncated line (the file ends mid-line: {_quoted(fh.last)}; {_name(exc)})"
                ) from None
            raise damage(fh.line, f"damaged line ({_name(exc)})") from None
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
    """The frames of the decoded CSV ``telethermo record`` writes; a damaged row, or a last row cut short
    (no end of line, and not all its columns or its ``fields`` JSON cut), is a ReplayError naming its line."""
    p = Path(p)

    def gen() -> Iterator[can.Message]:
        n, first, last = 0, None, None
        ended = [True]  # whether the last line csv took had its end of line

        def lines(fh) -> Iterator[str]:
            for text in fh:
                ended[0] = text.endswith("\n")
                yield text

        with open(p, newline="", encoding="utf-8") as fh:
            rows = csv.reader(lines(fh))
            head = next(rows, [])
            for row in rows:
                if not row:
                    continue
                try:
                    msg = _csv_message(row)
                    if not ended[0]:
                        _whole_row(row, head)
                except (ValueError, TypeError) as exc:
                    cut = "truncated" if not ended[0] else "damaged"
                    raise ReplayError(
                        f"{p}:{rows.line_num}: {cut} row ({exc}), {_what_was_read(n, first, last)}"
                    ) from None
                n, last = n + 1, msg.timestamp
                first = msg.timestamp if first is None else first
                yield msg

    return gen()


def _whole_row(row: list[str], head: list[str]) -> None:
    """ValueError unless a last row without its end of line has all the header's columns, whole."""
    if len(row) < len(head):
        raise ValueError(f"the file ends mid-row: {len(row)} of {len(head)} columns")
    if head and head[-1] == "fields":
        try:
            json.loads(row[len(head) - 1])
        except ValueError:
            raise ValueError("the file ends mid-row: its fields column is cut") from None
