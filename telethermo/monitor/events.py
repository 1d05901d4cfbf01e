"""The monitor's event log: what happened on the bus that a person should know, with a severity."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Any, Iterable

INFO, WARN, ERROR = "INFO", "WARN", "ERROR"
SEVERITIES = (INFO, WARN, ERROR)


@dataclass(slots=True)
class Event:
    """One event.

    Attributes:
        t_s: time of the frame (or tick) that revealed it, s.
        severity: INFO, WARN or ERROR.
        kind: short machine name: nmt, nmt_state, boot_up, heartbeat_lost, heartbeat_back, emcy,
            emcy_reset, sdo_abort, sdo_error, pdo_remap, pdo_length, pdo_missing, sync_counter,
            late_cycle, error_frame, controller_state, malformed, replay_error.
        node: the node concerned (None for the bus).
        text: one line for a person.
        fields: details (JSON-able).
    """

    t_s: float
    severity: str
    kind: str
    node: int | None
    text: str
    fields: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {
            "t_s": self.t_s,
            "type": "event",
            "severity": self.severity,
            "kind": self.kind,
            "node": self.node,
            "text": self.text,
            "fields": self.fields,
        }


class EventLog:
    """The last ``maxlen`` events and the count of every severity since the start."""

    def __init__(self, maxlen: int = 1000) -> None:
        self.events: deque[Event] = deque(maxlen=maxlen)
        self.counts = {s: 0 for s in SEVERITIES}

    def add(self, events: Iterable[Event]) -> None:
        for ev in events:
            self.events.append(ev)
            self.counts[ev.severity] += 1

    def last(self, n: int, *, predicate=None) -> list[Event]:
        out: list[Event] = []
        for ev in reversed(self.events):
            if predicate is None or predicate(ev):
                out.append(ev)
                if len(out) >= n:
                    break
        return out[::-1]
