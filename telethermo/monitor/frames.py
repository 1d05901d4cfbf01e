"""The raw frame list and the frame history of the monitor: one row per COB-ID (count, period, last
data, what it is), as every bus viewer has, and a bounded scrollback of the last decoded frames.
Plain data updated by :class:`~telethermo.monitor.state.Monitor`; no clock, no I/O."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Any

from .decoder import Frame

#: decoded frames kept for scrollback (at 8,000 frames/s: the last 0.25 s of a full bus, minutes of ours)
FRAME_HISTORY = 2000


@dataclass(slots=True)
class CobRow:
    """One identifier seen on the bus.

    Attributes:
        cob_id: the identifier; extended: 29-bit; kind / node: as decoded (see :class:`Frame`).
        count: frames seen; first_t_s / last_t_s: their first and last timestamps, s.
        period_last_s / period_min_s / period_max_s: intervals between consecutive frames, s.
        data: the last payload; text: the last frame's decoded line.
    """

    cob_id: int
    extended: bool
    kind: str
    node: int | None
    count: int = 0
    first_t_s: float = 0.0
    last_t_s: float = 0.0
    period_last_s: float | None = None
    period_min_s: float | None = None
    period_max_s: float | None = None
    data: bytes = b""
    text: str = ""

    @property
    def period_mean_s(self) -> float | None:
        """Mean interval since the first frame, s (None before the second frame)."""
        if self.count < 2:
            return None
        return (self.last_t_s - self.first_t_s) / (self.count - 1)

    def to_json(self) -> dict[str, Any]:
        return {
            "cob_id": self.cob_id,
            "extended": self.extended,
            "kind": self.kind,
            "node": self.node,
            "count": self.count,
            "period_mean_s": self.period_mean_s,
            "period_last_s": self.period_last_s,
            "period_min_s": self.period_min_s,
            "period_max_s": self.period_max_s,
            "data": self.data.hex(),
            "text": self.text,
        }


class FrameTable:
    """Rows by identifier and the last ``history`` decoded frames (oldest first)."""

    def __init__(self, history: int = FRAME_HISTORY) -> None:
        self.rows: dict[tuple[int, bool], CobRow] = {}
        self.history: deque[Frame] = deque(maxlen=history)

    def add(self, frame: Frame, extended: bool = False) -> None:
        key = (frame.cob_id, extended)
        row = self.rows.get(key)
        t = frame.t_s
        if row is None:
            row = self.rows[key] = CobRow(frame.cob_id, extended, frame.kind, frame.node, first_t_s=t)
        else:
            dt = t - row.last_t_s
            row.period_last_s = dt
            if row.period_min_s is None or dt < row.period_min_s:
                row.period_min_s = dt
            if row.period_max_s is None or dt > row.period_max_s:
                row.period_max_s = dt
        row.count += 1
        row.last_t_s = t
        row.data = frame.data
        row.text = frame.text
        row.kind, row.node = frame.kind, frame.node
        self.history.append(frame)

    def sorted_rows(self) -> list[CobRow]:
        """Rows by identifier (11-bit before 29-bit)."""
        return [self.rows[k] for k in sorted(self.rows, key=lambda k: (k[1], k[0]))]

    def clear_history(self) -> None:
        self.history.clear()
