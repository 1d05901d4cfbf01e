"""The one writer of recordings (telethermo.recording.format's CSV format): one CSV row per step,
streamed to a journal next to the target and renamed into place on close (a reader sees no file or the
whole one, never a torn one). The nodes stream their rows as they run; the offline runner writes its
finished recording through the same writer (:func:`telethermo.recording.format.write_recording_csv`).

The journal (``<target>.journal``, e.g. ``slave.csv.journal``) is the recording as written so far: the
same comment lines, header and rows. It is pushed to the OS and fsync'd every ``sync_interval_s``
(0.5 s) by a flusher thread, so a node killed with SIGKILL (or a machine that loses power) loses at
most that much, whether rows are still coming or not. The process holds an exclusive ``flock`` on it
while it writes, which the kernel releases when the process dies, however it dies.

A journal left by a killed node becomes a normal recording

- by :func:`recover_journal` (``telethermo-master --record FILE --recover``, ``telethermo-slave ...``):
  into FILE itself;
- at the next start of a recorder with the same target: into ``<stem>.killed-<UTC time><suffix>``
  beside it (the new run will write FILE), named in the log.

Recovery keeps every complete row (a row torn by the kill is dropped) and marks the meta line with
``"recovered": {...}``, so that nobody takes the file for a completed session.
"""

from __future__ import annotations

import csv
import datetime as _dt
import json
import logging
import os
import tempfile
import threading
from pathlib import Path
from typing import Any, BinaryIO, Iterable, Mapping, Sequence

from telethermo.atomic import file_mode

try:
    import fcntl
except ImportError:  # not POSIX: no lock (a journal in use could then be recovered under a running node)
    fcntl = None  # type: ignore[assignment]  # the module or None: tested before each use

log = logging.getLogger("telethermo.node")

JOURNAL_SUFFIX = ".journal"


class RecorderError(OSError):
    """A journal that cannot be recovered (names the file and why)."""


def journal_path(path: str | os.PathLike[str]) -> Path:
    """Where the recording of ``path`` is journaled while it is written."""
    path = Path(path)
    return path.with_name(path.name + JOURNAL_SUFFIX)


def _lock(fd: int, path: Path) -> None:
    if fcntl is None:
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        raise RecorderError(f"{path}: in use by a running node (locked)") from None
    except OSError as exc:  # a file system without locks (some network or 9p mounts): go on unlocked
        log.info("%s: not locked (%s)", path, exc)


def _fsync_dir(folder: Path) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


class CsvRecorder:
    """Write rows with fixed ``columns``; :meth:`close` makes the file appear atomically.

    Rows go to the journal (:func:`journal_path`), flushed and fsync'd every ``sync_interval_s`` by a
    thread and every ``flush_every`` rows by the writer. A journal of the same target left by a killed
    node is recovered first, into ``<stem>.killed-<time><suffix>`` (:attr:`recovered`).
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        columns: Sequence[str],
        *,
        flush_every: int = 200,
        sync_interval_s: float = 0.5,
        comments: Iterable[str] = (),
    ) -> None:
        self.path = Path(path)
        self.columns = tuple(columns)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.journal = journal_path(self.path)
        self.recovered: Path | None = None
        if self.journal.exists():
            self.recovered = recover_journal(self.path, target=_killed_name(self.path, self.journal))
            log.warning(
                "%s: the recording of a killed node was recovered into %s", self.journal, self.recovered
            )
        fd = os.open(self.journal, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        try:
            _lock(fd, self.journal)
        except RecorderError:
            os.close(fd)
            raise
        self._fh = os.fdopen(fd, "w", newline="", encoding="utf-8")
        comments = list(comments)
        for line in comments:
            self._fh.write(f"# {line}\n")
        self._writer = csv.writer(self._fh, lineterminator="\n")
        self._writer.writerow(self.columns)
        self._fh.flush()
        os.fsync(fd)
        _fsync_dir(self.path.parent)
        self._flush_every = max(1, flush_every)
        self._n_comments = len(comments)
        self._final_comments: list[str] | None = None
        self._io = threading.Lock()
        self.rows = 0
        self.syncs = 0
        self.closed = False
        self._stop = threading.Event()
        self._flusher = threading.Thread(
            target=self._flush_loop, args=(sync_interval_s,), name=f"journal-{self.path.name}", daemon=True
        )
        self._flusher.start()

    def write(self, row: Mapping[str, Any] | Sequence[Any]) -> None:
        values: Iterable[Any]
        if isinstance(row, Mapping):
            values = map(row.__getitem__, self.columns)
        elif len(row) != len(self.columns):
            raise ValueError(f"{self.path}: row has {len(row)} values, expected {len(self.columns)}")
        else:
            values = row
        # the csv module writes a float as str(), the shortest round-trip form (== repr for a float),
        # so only booleans need converting (to 0/1): one pass, no per-value function call on the per-SYNC path
        values = [int(v) if v.__class__ is bool else v for v in values]
        with self._io:
            self._writer.writerow(values)
            self.rows += 1
            if self.rows % self._flush_every == 0:
                self._fh.flush()

    def sync(self) -> None:
        """Push the rows written so far to the OS and to the disk (the flusher calls it)."""
        with self._io:
            if self.closed:
                return
            self._fh.flush()
            fd = self._fh.fileno()
        os.fsync(fd)  # outside the lock: the SYNC handler never waits for the disk
        self.syncs += 1

    def _flush_loop(self, interval_s: float) -> None:
        while not self._stop.wait(interval_s):
            try:
                self.sync()
            except (
                OSError,
                ValueError,
            ) as exc:  # disk full, file closed under us: say it, keep the node running
                log.error("%s: journal not synced: %s", self.journal, exc)

    def set_final_comments(self, comments: Iterable[str]) -> None:
        """Replace the leading comment lines when the file is closed (e.g. meta known only at the end;
        same number of lines as given at the start)."""
        comments = list(comments)
        if len(comments) != self._n_comments:
            raise ValueError(f"{self.path}: {len(comments)} final comment lines, expected {self._n_comments}")
        self._final_comments = comments

    def close(self) -> Path:
        """Flush, fsync and rename into place; idempotent."""
        if self.closed:
            return self.path
        self._stop.set()
        self._flusher.join()
        with self._io:
            self.closed = True
            self._fh.flush()
            os.fsync(self._fh.fileno())
            if self._final_comments is None:
                os.replace(self.journal, self.path)
            else:
                with open(self.journal, encoding="utf-8", newline="") as src:
                    lines = src.readlines()
                head = [f"# {c}\n" for c in self._final_comments]
                _write_atomic(self.path, "".join(head + lines[self._n_comments :]))
                self.journal.unlink()
            self._fh.close()
        _fsync_dir(self.path.parent)
        return self.path

    def abort(self) -> None:
        """Drop the recording (the target is left untouched)."""
        if not self.closed:
            self._stop.set()
            self._flusher.join()
            with self._io:
                self.closed = True
                self._fh.close()
                self.journal.unlink(missing_ok=True)


def _write_atomic(path: Path, text: str) -> None:
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.fchmod(fd, file_mode())  # mkstemp's 0600 would hide the recording from the lab's group
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _killed_name(path: Path, journal: Path) -> Path:
    """``<stem>.killed-<journal's UTC mtime><suffix>`` beside ``path``, not yet taken."""
    when = _dt.datetime.fromtimestamp(journal.stat().st_mtime, _dt.timezone.utc).strftime("%Y%m%dT%H%M%SZ")
    for n in range(1, 1000):
        tag = f"killed-{when}" + (f"-{n}" if n > 1 else "")
        cand = path.with_name(f"{path.stem}.{tag}{path.suffix}")
        if not cand.exists():
            return cand
    raise RecorderError(f"{path}: no free name for the recovered recording")


def recover_journal(path: str | os.PathLike[str], *, target: str | os.PathLike[str] | None = None) -> Path:
    """Turn the journal of ``path`` (left by a killed node) into a normal recording at ``target``
    (default ``path``); return ``target``.

    Every complete row is kept; a row torn by the kill (no line end, or the wrong number of fields)
    ends the rows. A ``# meta {json}`` line gets ``"recovered": {"journal", "rows", "dropped_tail_bytes"}``.
    Raises :class:`RecorderError` if there is no journal, if a running node holds it, or if it has no
    header line.
    """
    path = Path(path)
    journal = journal_path(path)
    target = Path(target) if target is not None else path
    try:
        fd = os.open(journal, os.O_RDWR)
    except FileNotFoundError:
        raise RecorderError(
            f"{journal}: no journal to recover (the recording was closed normally, or never started)"
        ) from None
    try:
        _lock(fd, journal)
        with os.fdopen(os.dup(fd), "rb") as fh:  # streamed: a journal of hours is not read into memory
            comments, header, rows, body_bytes = _scan(fh, journal)
            total = fh.seek(0, os.SEEK_END)
            head = "".join(comments) + header
            dropped = total - len(head.encode("utf-8")) - body_bytes
            info = {"journal": journal.name, "rows": rows, "dropped_tail_bytes": dropped}
            fh.seek(len(head.encode("utf-8")))
            out_fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
            try:
                os.fchmod(out_fd, file_mode())  # as the recording a node closes normally, not mkstemp's 0600
                with os.fdopen(out_fd, "wb") as out:
                    out.write("".join(_mark_meta(c, info) for c in comments).encode("utf-8"))
                    out.write(header.encode("utf-8"))
                    left = body_bytes
                    while left:
                        chunk = fh.read(min(left, 1 << 20))
                        if not chunk:
                            raise RecorderError(f"{journal}: shrank while it was recovered")
                        out.write(chunk)
                        left -= len(chunk)
                    out.flush()
                    os.fsync(out.fileno())
                os.replace(tmp, target)
            except BaseException:
                Path(tmp).unlink(missing_ok=True)
                raise
        journal.unlink()
        _fsync_dir(target.parent)
    finally:
        os.close(fd)
    log.warning(
        "%s: recovered %d rows into %s (%d bytes of a torn row dropped)", journal, rows, target, dropped
    )
    return target


def _scan(fh: BinaryIO, journal: Path) -> tuple[list[str], str, int, int]:
    """The comment lines and the header of a journal, the number of complete rows after them (each ended
    by a line end, with as many fields as the header) and their size in bytes."""
    comments: list[str] = []
    line = fh.readline()
    while line.startswith(b"#") and line.endswith(b"\n"):
        comments.append(line.decode("utf-8", errors="replace"))
        line = fh.readline()
    if not line.endswith(b"\n") or line.startswith(b"#"):
        raise RecorderError(f"{journal}: no header line: nothing to recover")
    header = line.decode("utf-8", errors="replace")
    n_fields = len(next(csv.reader([header])))
    rows = body = 0
    for line in fh:
        if (
            not line.endswith(b"\n")
            or len(next(csv.reader([line.decode("utf-8", errors="replace")]), [])) != n_fields
        ):
            break
        rows += 1
        body += len(line)
    return comments, header, rows, body


def _mark_meta(line: str, info: dict[str, Any]) -> str:
    if not line.startswith("# meta "):
        return line
    try:
        meta = json.loads(line[len("# meta ") :])
    except ValueError:
        return line
    if not isinstance(meta, dict):
        return line
    meta["recovered"] = info
    return "# meta " + json.dumps(meta, sort_keys=True, default=str) + "\n"
