"""The simulated plant's truth behind an I/O module, one row per SYNC (``telethermo-iomodule --record FILE``).

A controller on ``--rig io`` sees only the module's 16-bit inputs; the simulator's truth (the operator's skin,
the true contact flux) lives in the module's process. ``telethermo session --io`` asks each module to write it
here and puts it into the session recording's ``X_true_*`` columns (the figures' transparency is skin vs the
direct-touch skin), matched on ``sync_cycle``: the module numbers the SYNCs it sees from 0, as the nodes do
(it is up before the producer's first SYNC). Each row is the plant after that SYNC's advance, i.e. what the
inputs converted at that SYNC show.

Columns: ``sync_cycle``, ``t_s`` (plant time, s), then ``X_true_surface_C``, ``X_true_Q_W``,
``X_true_Q_into_body_W``, ``X_true_touching`` (and ``m_true_finger_C`` on the master's side) with X = m or s.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import IO, Any

from telethermo.recording.rows import truth_row

SIDE_PREFIX = {"master": "m", "slave": "s"}


class TruthLog:
    """Rows of ``rig``'s truth into the CSV file ``path``: :meth:`on_sync` after the module's own SYNC
    handler (the plant advanced), :meth:`close` at the end."""

    def __init__(self, path: Path, rig: Any, side: str) -> None:
        self.rig = rig
        self.prefix = SIDE_PREFIX[side]
        path.parent.mkdir(parents=True, exist_ok=True)
        self._file: IO[str] | None = open(path, "w", encoding="utf-8", newline="")
        self._writer: Any = None
        self.rows = 0

    def on_sync(self, tick: object) -> None:
        if self._file is None:
            return
        row: dict[str, Any] = {"sync_cycle": self.rows, "t_s": float(self.rig.t_s)}
        row.update(truth_row(self.prefix, self.rig))
        if self._writer is None:
            self._writer = csv.DictWriter(self._file, fieldnames=list(row))
            self._writer.writeheader()
        self._writer.writerow({k: _text(v) for k, v in row.items()})
        self.rows += 1
        if self.rows % 100 == 0:
            self._file.flush()

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None


def _text(v: Any) -> str:
    if isinstance(v, float):
        return "nan" if not math.isfinite(v) else repr(v)
    return str(v)


def read_truth_log(path: Path) -> dict[str, list[float]]:
    """The columns of a truth log (ValueError naming the file and line on a bad row)."""
    with open(path, encoding="utf-8", newline="") as f:
        reader = csv.DictReader(f)
        cols: dict[str, list[float]] = {name: [] for name in reader.fieldnames or []}
        for line, row in enumerate(reader, 2):
            try:
                for name, value in row.items():
                    cols[name].append(float(value))
            except (TypeError, ValueError):
                raise ValueError(f"{path}: line {line}: expected numbers in every column") from None
    if "sync_cycle" not in cols:
        raise ValueError(f"{path}: no sync_cycle column (not a truth log of telethermo-iomodule --record)")
    return cols
