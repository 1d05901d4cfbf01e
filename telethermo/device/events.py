"""What the device hands its listeners: SYNC ticks, accepted RPDOs, heartbeat-consumer events, SDO
writes; and the error of a refused local write."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True, slots=True)
class SyncTick:
    """What a SYNC handler gets.

    Attributes:
        counter: the SYNC counter (1..0x1019) or None for a SYNC without counter.
        fresh_rpdos: numbers of the synchronous RPDOs whose data were written into the OD at this
            SYNC (i.e. received since the previous SYNC).
        operational: True in OPERATIONAL (TPDOs follow the handlers), False in PRE-OPERATIONAL.
    """

    counter: int | None
    fresh_rpdos: tuple[int, ...]
    operational: bool


@dataclass(frozen=True, slots=True)
class RpdoEvent:
    """An accepted RPDO: its number, named values, the last SYNC counter seen, receive time (s)."""

    number: int
    values: dict[str, float | int | bytes]
    sync_counter: int | None
    timestamp: float


@dataclass(frozen=True, slots=True)
class PeerEvent:
    """Heartbeat consumer event. ``kind``: "seen" (first heartbeat), "lost" (timeout), "back"
    (heartbeat after a loss), "bootup" (the peer sent a boot-up message), "state" (an alive peer's
    heartbeat reports another NMT state than its previous one, e.g. put into PRE-OPERATIONAL by
    another NMT master). ``state``: the peer's NMT state code from the heartbeat (None for "lost")."""

    node_id: int
    kind: str
    state: int | None


@dataclass(frozen=True, slots=True)
class WriteEvent:
    """A successful SDO write: where, the decoded value."""

    index: int
    subindex: int
    value: Any


class OdWriteError(ValueError):
    """A local write was refused; ``code`` is the SDO abort code a remote write would have got."""

    def __init__(self, message: str, code: int):
        super().__init__(message)
        self.code = code
