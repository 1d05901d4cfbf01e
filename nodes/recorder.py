"""A node's recording: one CSV row per cycle, streamed to a temporary file next to the target and
renamed into place on close (a reader sees no file or the whole one, never a torn one)."""
from __future__ import annotations

import csv
import os
import tempfile
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence


class CsvRecorder:
    """Write rows with fixed ``columns``; :meth:`close` makes the file appear atomically.

    ``flush_every`` rows are pushed to the OS, so a SIGTERM'd node loses nothing and a killed one
    leaves its rows in the hidden temporary file (``.<name>.*.tmp``) for inspection.
    """

    def __init__(self, path: str | os.PathLike, columns: Sequence[str], *, flush_every: int = 200,
                 comments: Iterable[str] = ()) -> None:
        self.path = Path(path)
        self.columns = tuple(columns)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{self.path.name}.", suffix=".tmp", dir=self.path.parent)
        self._tmp = Path(tmp)
        self._fh = os.fdopen(fd, "w", newline="", encoding="utf-8")
        comments = list(comments)
        for line in comments:
            self._fh.write(f"# {line}\n")
        self._writer = csv.writer(self._fh, lineterminator="\n")
        self._writer.writerow(self.columns)
        self._flush_every = max(1, flush_every)
        self._n_comments = len(comments)
        self._final_comments: list[str] | None = None
        self.rows = 0
        self.closed = False

    def write(self, row: Mapping[str, Any] | Sequence[Any]) -> None:
        if isinstance(row, Mapping):
            values = [row[c] for c in self.columns]
        else:
            if len(row) != len(self.columns):
                raise ValueError(f"{self.path}: row has {len(row)} values, expected {len(self.columns)}")
            values = list(row)
        # the csv module writes a float as str(), the shortest round-trip form (== repr for a float),
        # so only booleans need converting (to 0/1): no per-value function call on the per-SYNC path
        self._writer.writerow([int(v) if v.__class__ is bool else v for v in values])
        self.rows += 1
        if self.rows % self._flush_every == 0:
            self._fh.flush()

    def set_final_comments(self, comments: Iterable[str]) -> None:
        """Replace the leading comment lines when the file is closed (e.g. meta known only at the end;
        same number of lines as given at the start)."""
        comments = list(comments)
        if len(comments) != self._n_comments:
            raise ValueError(f"{self.path}: {len(comments)} final comment lines, expected {self._n_comments}")
        self._final_comments = comments

    def close(self) -> Path:
        """Flush, fsync and rename into place; idempotent."""
        if not self.closed:
            self.closed = True
            self._fh.flush()
            self._fh.close()
            if self._final_comments is not None:
                with open(self._tmp, encoding="utf-8") as src:
                    lines = src.readlines()
                head = [f"# {c}\n" for c in self._final_comments]
                with open(self._tmp, "w", encoding="utf-8", newline="") as dst:
                    dst.writelines(head + lines[self._n_comments:])
            with open(self._tmp, "rb+") as fh:
                os.fsync(fh.fileno())
            os.replace(self._tmp, self.path)
        return self.path

    def abort(self) -> None:
        """Drop the recording (the target is left untouched)."""
        if not self.closed:
            self.closed = True
            self._fh.close()
            self._tmp.unlink(missing_ok=True)

