"""Record the bus: every frame to a python-can log file (format by extension) plus a decoded CSV.

Both files are written to temporary names in the target folder and renamed into place when the
recording stops, so a reader never sees a half-written file and an aborted recording leaves the
previous files intact (:mod:`telethermo.atomic`'s rule, for streams).
"""
from __future__ import annotations

import copy
import csv
import json
import os
import tempfile
import threading
from pathlib import Path

import can
from can.util import channel2int

from .state import Monitor

#: log formats by extension (python-can writers): candump text, Vector ASC, Vector BLF, PEAK trace
LOG_FORMATS = {".log": "candump -L text", ".asc": "Vector ASC", ".blf": "Vector BLF", ".trc": "PEAK trace 2.1"}
CSV_COLUMNS = ("t_s", "cob_id", "kind", "node", "dlc", "data", "text", "fields")


class RecordError(ValueError):
    """A recording target that cannot be used (names the file and what was expected)."""


def check_log_path(path: str | os.PathLike) -> Path:
    """The log path if its extension is a supported format; RecordError otherwise."""
    p = Path(path)
    if p.suffix.lower() not in LOG_FORMATS:
        raise RecordError(f"{p}: unsupported log format {p.suffix or '(no extension)'!r}; expected one of "
                          + ", ".join(f"{k} ({v})" for k, v in LOG_FORMATS.items()))
    if p.exists() and p.is_dir():
        raise RecordError(f"{p}: is a folder, expected a file name")
    return p


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


def _temp_beside(path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    return Path(tmp)


class Recorder(can.Listener):
    """A python-can listener writing the log and the decoded CSV; call :meth:`stop` to finish.

    Args:
        log_path: ``.log`` / ``.asc`` / ``.blf`` file.
        csv_path: decoded frames as CSV (None: no CSV).
        monitor: decodes the frames for the CSV (a fresh :class:`Monitor` if None).
    """

    def __init__(self, log_path: str | os.PathLike, csv_path: str | os.PathLike | None = None,
                 monitor: Monitor | None = None) -> None:
        self.log_path = check_log_path(log_path)
        self.csv_path = Path(csv_path) if csv_path else None
        self.monitor = monitor or Monitor()
        self.frames = 0
        self._lock = threading.Lock()
        self._tmp_log = _temp_beside(self.log_path)
        self._writer = can.Logger(str(self._tmp_log))
        self._tmp_csv = _temp_beside(self.csv_path) if self.csv_path else None
        self._csv_fh = open(self._tmp_csv, "w", newline="", encoding="utf-8") if self._tmp_csv else None
        self._csv = csv.writer(self._csv_fh) if self._csv_fh else None
        if self._csv:
            self._csv.writerow(CSV_COLUMNS)
        self._stopped = False

    def on_message_received(self, msg: can.Message) -> None:
        with self._lock:
            if self._stopped:
                return
            out = msg
            ch = channel2int(msg.channel) if msg.channel is not None else None
            if msg.channel is not None and (ch is None or not 0 <= ch <= 0xFFFF):
                out = copy.copy(msg)      # BLF/ASC need a small channel number
                out.channel = None
            self._writer.on_message_received(out)
            self.frames += 1
            if self._csv:
                frame, _ = self.monitor.feed(msg)
                self._csv.writerow([f"{frame.t_s:.6f}", f"0x{frame.cob_id:03X}", frame.kind,
                                    "" if frame.node is None else frame.node, len(frame.data), frame.data.hex(),
                                    frame.text, json.dumps(frame.fields, default=str, allow_nan=True)])

    def stop(self) -> int:
        """Close both files and move them into place; the number of frames recorded."""
        with self._lock:
            if self._stopped:
                return self.frames
            self._stopped = True
            self._writer.stop()
            mode = _file_mode()   # the temporary files are 0600 (mkstemp); the recordings are for the group too
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
