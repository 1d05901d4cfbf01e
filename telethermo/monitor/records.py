"""The records the monitor's state machine (:mod:`telethermo.monitor.state`) keeps: its settings, each
node's state, each PDO's last values, the finished SDO transfers and the bus statistics. Plain data with
their JSON forms; no clock, no I/O."""

from __future__ import annotations

import math
import statistics
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from telethermo import cia301
from .pdo import PdoDef, PdoValue, format_value
from .sdo import SdoChannel, SdoTransfer


#: a node with no producer or consumer time in the settings counts as lost after this many times the longest
#: heartbeat period measured, once it has beaten this often (a lab's CiA 401 module beats at its own 0x1017)
MEASURED_FACTOR = 2.0
MEASURED_MIN_BEATS = 4


@dataclass(frozen=True)
class NodeInfo:
    """What the monitor knows of a node before it sees it: its name and object dictionary."""

    name: str
    od: Any = None  # canopen.ObjectDictionary (from the node's EDS) or None


@dataclass
class MonitorConfig:
    """Settings of one monitor.

    Attributes:
        nodes: node-ID -> NodeInfo (name, EDS object dictionary); unknown nodes are still decoded.
        bitrate_bps: the bus bitrate, bit/s (for the bus load).
        sync_period_s: nominal SYNC period, s; a SYNC interval longer than
            ``sync_period_s * (1 + late_tolerance)`` is a late cycle. None: no late-cycle count.
        sync_lockstep: the network runs in lockstep (SYNC k+1 after cycle k's PDOs): a late cycle is
            then the simulation running slower than real time, not a fault.
        late_tolerance: fraction of the period a SYNC may be late before the cycle counts as late.
        window_s: window of frames/s and bus load, s.
        heartbeat_timeout_factor: without a consumer time (0x1016) for a node, its heartbeat times out
            after this many producer periods (0x1017).
    """

    nodes: dict[int, NodeInfo] = field(default_factory=dict)
    bitrate_bps: int = 1_000_000
    sync_period_s: float | None = None
    sync_lockstep: bool = False
    late_tolerance: float = 0.5
    window_s: float = 1.0
    heartbeat_timeout_factor: float = 1.5


@dataclass
class SdoRecord:
    """A finished SDO transfer with what the EDS says about the object."""

    transfer: SdoTransfer
    name: str
    value: Any
    unit: str

    def text(self) -> str:
        tr = self.transfer
        arrow = (
            "write" if tr.direction == "download" else "read" if tr.direction == "upload" else tr.direction
        )
        where = f"0x{tr.index:04X}:{tr.subindex:02X} {self.name}".rstrip()
        if tr.status == "ok":
            shown = (
                f"0x{self.value:X}"
                if isinstance(self.value, int)
                and not isinstance(self.value, bool)
                and 0x1000 <= tr.index < 0x2000
                else format_value(self.value, self.unit)
            )
            return f"{arrow} {where} = {shown} ({tr.mode})"
        if tr.status == "aborted":
            return f"{arrow} {where} ABORT 0x{tr.abort_code:08X} {tr.abort_text} (by {tr.aborted_by})"
        return f"{arrow} {where} ERROR {tr.problem}"

    def to_json(self) -> dict[str, Any]:
        out = self.transfer.to_json()
        v = self.value
        if isinstance(v, (bytes, bytearray)):
            v = bytes(v).hex()
        elif isinstance(v, float) and not math.isfinite(v):
            v = str(v)
        out.update(type="sdo", name=self.name, value=v, unit=self.unit, text=self.text())
        return out


@dataclass
class NodeState:
    """Everything the monitor learnt about one node."""

    node: int
    name: str = ""
    nmt_state: str = cia301.NMT_UNKNOWN
    heartbeats: int = 0
    boot_ups: int = 0
    last_hb_t: float | None = None
    hb_period_min_s: float | None = None
    hb_period_max_s: float | None = None
    hb_period_last_s: float | None = None
    producer_time_s: float | None = None  # 0x1017 of the node
    consumer_time_s: float | None = None  # the shortest 0x1016 entry watching it
    hb_lost: bool = False
    hb_losses: int = 0
    nmt_pending: str | None = None  # an NMT command was seen, heartbeat not yet confirming
    reset_pending: bool = False
    after_boot: bool = False
    last_emcy: dict[str, Any] | None = None
    last_emcy_t: float | None = None
    emcys: int = 0
    emcy_active: bool = False  # the last EMCY was an error, not a reset (0x0000)
    error_register: int | None = None
    sdo: SdoChannel | None = None
    sdo_transfers: deque = field(default_factory=lambda: deque(maxlen=8))
    sdo_ok: int = 0
    sdo_aborts: int = 0
    pdo_frames: dict[str, int] = field(default_factory=dict)

    @property
    def hb_timeout_s(self) -> float | None:
        """Time without heartbeat after which the node counts as lost, s: the consumer time watching it, else
        1.5 × its producer time (0x1017, network settings), else, for a node the settings do not name (a
        lab's I/O module), :data:`MEASURED_FACTOR` × the longest period measured over at least
        :data:`MEASURED_MIN_BEATS` heartbeats."""
        if self.consumer_time_s:
            return self.consumer_time_s
        if self.producer_time_s:
            return self.producer_time_s * self._factor
        if self.heartbeats >= MEASURED_MIN_BEATS and self.hb_period_max_s:
            return self.hb_period_max_s * MEASURED_FACTOR
        return None

    _factor: float = 1.5

    @property
    def hb_timeout_from(self) -> str:
        """What :attr:`hb_timeout_s` comes from: "consumer time", "timeout" (the producer time) or
        "measured period"."""
        if self.consumer_time_s:
            return "consumer time"
        return "timeout" if self.producer_time_s else "measured period"

    def to_json(self) -> dict[str, Any]:
        return {
            "node": self.node,
            "name": self.name,
            "nmt_state": self.nmt_state,
            "heartbeats": self.heartbeats,
            "boot_ups": self.boot_ups,
            "hb_period_min_s": self.hb_period_min_s,
            "hb_period_max_s": self.hb_period_max_s,
            "hb_period_last_s": self.hb_period_last_s,
            "producer_time_s": self.producer_time_s,
            "consumer_time_s": self.consumer_time_s,
            "hb_timeout_s": self.hb_timeout_s,
            "hb_lost": self.hb_lost,
            "hb_losses": self.hb_losses,
            "last_emcy": self.last_emcy,
            "last_emcy_t_s": self.last_emcy_t,
            "emcy_active": self.emcy_active,
            "emcys": self.emcys,
            "error_register": self.error_register,
            "sdo_ok": self.sdo_ok,
            "sdo_aborts": self.sdo_aborts,
            "last_sdo": [r.to_json() for r in self.sdo_transfers][-1:],
            "pdo_frames": dict(self.pdo_frames),
        }


#: the strip chart's sampling: one sample of a PDO's values per this bus time, s, the last STRIP_POINTS kept
STRIP_DT_S = 0.1
STRIP_POINTS = 300


@dataclass
class PdoState:
    """Last values of one PDO as seen on the bus, and a sampled trace of them for the strip chart
    (``trace``: (t_s, values) every :data:`STRIP_DT_S` of bus time)."""

    pdef: PdoDef
    count: int = 0
    last_t: float | None = None
    values: list[PdoValue] = field(default_factory=list)
    missing: int = 0
    missing_streak: int = 0
    armed: bool = False
    unreported: int = 0  # missing cycles not yet in an event
    event_t: float | None = None  # time of the last pdo_missing event
    trace: deque = field(default_factory=lambda: deque(maxlen=STRIP_POINTS))
    trace_t: float | None = None  # time of the last sample in ``trace``


@dataclass
class BusStats:
    """Bus-wide figures for the status bar."""

    frames: int = 0
    bits: int = 0
    error_frames: int = 0
    unknown_frames: int = 0
    malformed: int = 0
    syncs: int = 0
    sync_counter: int | None = None
    sync_counter_errors: int = 0
    sync_intervals_s: deque = field(default_factory=lambda: deque(maxlen=500))
    late_cycles: int = 0
    missed_pdos: int = 0
    frames_per_s: float = 0.0
    bus_load: float = 0.0  # fraction of the bitrate
    t_first: float | None = None
    t_last: float | None = None

    def sync_summary(self) -> dict[str, float | None]:
        """Mean SYNC period, its standard deviation (jitter), min and max over the last 500, s."""
        iv = list(self.sync_intervals_s)
        if not iv:
            return {"period_s": None, "jitter_s": None, "min_s": None, "max_s": None}
        return {
            "period_s": statistics.fmean(iv),
            "jitter_s": statistics.pstdev(iv) if len(iv) > 1 else 0.0,
            "min_s": min(iv),
            "max_s": max(iv),
        }
