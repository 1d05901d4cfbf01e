"""Record the bus: every frame to a python-can log file (format by extension) plus a decoded CSV.

Both files are written to temporary names in the target folder and renamed into place when the
recording stops, so a reader never sees a half-written file and an aborted recording leaves the
previous files intact (:mod:`telethermo.atomic`'s rule, for streams). Appending (``.log`` and ``.blf``,
the formats python-can appends to) copies the existing files to the temporary ones first, so it keeps
that rule. The folder must exist: a typo in a path is said, not turned into new folders.

A candump ``.log`` keeps each frame's channel name (``telethermo`` for our hub, ``can0``...); the Vector
and PEAK formats number their channels, so a named channel is written as their first channel there.
"""

from __future__ import annotations

import copy
import csv
import json
import os
import shutil
import tempfile
import threading
from pathlib import Path
from typing import Callable

import can
from can.util import channel2int

from .state import Monitor

#: log formats by extension (python-can writers): candump text, Vector ASC, Vector BLF, PEAK trace
LOG_FORMATS = {
    ".log": "candump -L text",
    ".asc": "Vector ASC",
    ".blf": "Vector BLF",
    ".trc": "PEAK trace 2.1",
}
CSV_COLUMNS = ("t_s", "cob_id", "kind", "node", "dlc", "data", "text", "fields")
#: formats python-can's writers append to (ASC and TRC writers refuse to)
APPENDABLE = (".log", ".blf")


class RecordError(ValueError):
    """A recording target that cannot be used (names the file and what was expected)."""


def check_log_path(path: str | os.PathLike) -> Path:
    """The log path if its extension is a supported format; RecordError otherwise."""
    p = Path(path)
    if p.suffix.lower() not in LOG_FORMATS:
        raise RecordError(
            f"{p}: unsupported log format {p.suffix or '(no extension)'!r}; expected one of "
            + ", ".join(f"{k} ({v})" for k, v in LOG_FORMATS.items())
        )
    if p.exists() and p.is_dir():
        raise RecordError(f"{p}: is a folder, expected a file name")
    check_folder(p)
    return p


def check_folder(path: Path) -> None:
    """RecordError naming the folder if ``path``'s folder does not exist (it is not created)."""
    folder = path.parent
    if not folder.is_dir():
        what = "is not a folder" if folder.exists() else "does not exist"
        raise RecordError(
            f"{path}: the folder {folder} {what}; expected an existing folder (create it first)"
        )


def default_csv_path(log_path: str | os.PathLike) -> Path:
    """The decoded CSV of a log: its full name plus ``.csv`` (``s.blf`` -> ``s.blf.csv``), so that ``s.log``,
    ``s.blf`` and ``s.asc`` each keep their own CSV."""
    p = Path(log_path)
    return p.with_name(p.name + ".csv")


def _file_mode() -> int:
    """What ``open()`` would give a new file: 0666 less the umask (0644 under the usual 022)."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


def _temp_beside(path: Path, copy_of: Path | None = None) -> Path:
    """A new temporary file in ``path``'s folder (which must exist); with ``copy_of``'s bytes if given."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    if copy_of is not None:
        shutil.copyfile(copy_of, tmp)
    return Path(tmp)


def _channel(msg: can.Message, suffix: str):
    """The channel to write: a candump log keeps a name (blanks would split its line); the numbered
    formats get None (their first channel) for a name or a number out of their range."""
    if msg.channel is None:
        return None
    if suffix == ".log" and isinstance(msg.channel, str):
        return "_".join(msg.channel.split()) or None
    ch = channel2int(msg.channel)
    return ch if ch is not None and 0 <= ch <= 0xFFFF else None


def check_append(log: Path, csv_path: Path | None) -> None:
    """RecordError if ``--append`` cannot keep the rule: a format python-can cannot append to, or an
    existing CSV that is not this recorder's (its header)."""
    if log.suffix.lower() not in APPENDABLE:
        raise RecordError(
            f"{log}: cannot append to a {log.suffix} log (python-can's writer cannot); "
            f"expected one of {', '.join(APPENDABLE)}"
        )
    if csv_path is not None and csv_path.exists():
        with open(csv_path, newline="", encoding="utf-8", errors="replace") as fh:
            head = next(csv.reader(fh), [])
        if tuple(head) != CSV_COLUMNS:
            raise RecordError(
                f"{csv_path}:1: not the decoded CSV of telethermo record; expected the header "
                f"{','.join(CSV_COLUMNS)}"
            )


class Recorder(can.Listener):
    """A python-can listener writing the log and the decoded CSV; call :meth:`stop` to finish.

    Args:
        log_path: ``.log`` / ``.asc`` / ``.blf`` file.
        csv_path: decoded frames as CSV (None: no CSV).
        monitor: decodes the frames for the CSV (a fresh :class:`Monitor` if None).
        keep: which frames to record (:func:`telethermo.monitor.filters.frame_filter`; None: all).
        append: add to the existing files (.log and .blf; :func:`check_append`) instead of replacing.
    """

    def __init__(
        self,
        log_path: str | os.PathLike,
        csv_path: str | os.PathLike | None = None,
        monitor: Monitor | None = None,
        *,
        keep: Callable[[can.Message], bool] | None = None,
        append: bool = False,
    ) -> None:
        self.log_path = check_log_path(log_path)
        self.csv_path = Path(csv_path) if csv_path else None
        if self.csv_path is not None:
            check_folder(self.csv_path)
        if append:
            check_append(self.log_path, self.csv_path)
        self.monitor = monitor or Monitor()
        self.keep = keep
        self.frames = 0
        self._suffix = self.log_path.suffix.lower()
        self._lock = threading.Lock()
        old_log = self.log_path if append and self.log_path.is_file() else None
        self._tmp_log = _temp_beside(self.log_path, old_log)
        self._writer = can.Logger(str(self._tmp_log), **({"append": True} if old_log else {}))
        old_csv = self.csv_path if append and self.csv_path and self.csv_path.is_file() else None
        self._tmp_csv = _temp_beside(self.csv_path, old_csv) if self.csv_path else None
        self._csv_fh = (
            open(self._tmp_csv, "a" if old_csv else "w", newline="", encoding="utf-8")
            if self._tmp_csv
            else None
        )
        self._csv = csv.writer(self._csv_fh) if self._csv_fh else None
        if self._csv and not old_csv:
            self._csv.writerow(CSV_COLUMNS)
        self._stopped = False

    def on_message_received(self, msg: can.Message) -> None:
        with self._lock:
            if self._stopped:
                return
            if self.keep is not None and not self.keep(msg):
                if self._csv:
                    self.monitor.feed(msg)  # the decoding follows the whole bus (SDO remaps, SYNC counter)
                return
            out = msg
            channel = _channel(msg, self._suffix)
            if channel != msg.channel:
                out = copy.copy(msg)
                out.channel = channel
            self._writer.on_message_received(out)
            self.frames += 1
            if self._csv:
                frame, _ = self.monitor.feed(msg)
                self._csv.writerow(
                    [
                        f"{frame.t_s:.6f}",
                        f"0x{frame.cob_id:03X}",
                        frame.kind,
                        "" if frame.node is None else frame.node,
                        len(frame.data),
                        frame.data.hex(),
                        frame.text,
                        json.dumps(frame.fields, default=str, allow_nan=True),
                    ]
                )

    def stop(self) -> int:
        """Close both files and move them into place; the number of frames recorded."""
        with self._lock:
            if self._stopped:
                return self.frames
            self._stopped = True
            self._writer.stop()
            mode = (
                _file_mode()
            )  # the temporary files are 0600 (mkstemp); the recordings are for the group too
            os.chmod(self._tmp_log, mode)
            os.replace(self._tmp_log, self.log_path)
            if self._csv_fh:
                self._csv_fh.flush()
                os.fsync(self._csv_fh.fileno())
                self._csv_fh.close()
                os.chmod(self._tmp_csv, mode)
                os.replace(self._tmp_csv, self.csv_path)
        return self.frames

    def discard(self) -> None:
        """Stop without keeping anything (the previous files, if any, stay)."""
        with self._lock:
            self._stopped = True
            try:
                self._writer.stop()
            finally:
                if self._csv_fh:
                    self._csv_fh.close()
                for p in (self._tmp_log, self._tmp_csv):
                    if p and p.exists():
                        p.unlink()
