"""The network settings file (bus_config/network.toml): load, validate, and turn into device settings.

Every field is checked; a bad file raises :class:`NetworkConfigError` whose message names the file,
the field (``[section] key``) and what was expected, e.g.::

    bus_config/network.toml: [heartbeat] consumer_ms: expected an integer > producer_ms (100), got 80
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from telethermo.device.settings import DeviceSettings
from telethermo.bus_config import path
from telethermo.bus_config.edsgen import CONTACT_PDO_BASE, IDENT_PDO_BASE

ROLES = ("master", "slave")


class NetworkConfigError(ValueError):
    """A network settings file is missing, unreadable or has a bad field."""


@dataclass(frozen=True, slots=True)
class BusConfig:
    """How to open the bus with python-can: ``can.Bus(**bus.can_kwargs())``."""

    interface: str = "virtual"
    channel: str = "telethermo"
    bitrate: int = 1_000_000
    options: dict[str, Any] = field(default_factory=dict)

    def can_kwargs(self) -> dict[str, Any]:
        """Keyword arguments for ``can.Bus``."""
        return {"interface": self.interface, "channel": self.channel, "bitrate": self.bitrate, **self.options}


@dataclass(frozen=True, slots=True)
class SyncConfig:
    producer: str = "master"  # "master", "slave" or "none"
    period_s: float = 0.010
    counter_overflow: int = 240
    lockstep: bool = True


@dataclass(frozen=True, slots=True)
class HeartbeatConfig:
    producer_ms: int = 100
    consumer_ms: int = 250


@dataclass(frozen=True, slots=True)
class NodeConfig:
    role: str
    node_id: int
    eds: Path


@dataclass(frozen=True, slots=True)
class NetworkConfig:
    """The whole file. ``nodes`` maps role ("master"/"slave") to its NodeConfig."""

    path: Path
    bus: BusConfig
    sync: SyncConfig
    heartbeat: HeartbeatConfig
    nodes: dict[str, NodeConfig]

    def node(self, role: str) -> NodeConfig:
        if role not in self.nodes:
            raise NetworkConfigError(f"{self.path}: [nodes.{role}]: no such node (have {', '.join(self.nodes)})")
        return self.nodes[role]

    def peer(self, role: str) -> NodeConfig:
        """The other node of the pair."""
        self.node(role)
        return self.node("slave" if role == "master" else "master")

    def device_settings(self, role: str) -> DeviceSettings:
        """Power-on settings of ``role``'s device: heartbeat times, SYNC role/period/counter, peers."""
        me, peer = self.node(role), self.peer(role)
        return DeviceSettings(
            heartbeat_producer_ms=self.heartbeat.producer_ms,
            heartbeat_consumers=((peer.node_id, self.heartbeat.consumer_ms),),
            sync_producer=self.sync.producer == role,
            sync_period_us=round(self.sync.period_s * 1e6),
            sync_counter_overflow=self.sync.counter_overflow,
            known_node_ids=tuple(sorted(n.node_id for n in self.nodes.values())),
            # RPDO1 <- the peer's TPDO1, RPDO2 <- its contact TPDO5, the master's RPDO3 <- the slave's TPDO6
            rpdo_cob_ids=(0x180 + peer.node_id, CONTACT_PDO_BASE + peer.node_id)
            + ((IDENT_PDO_BASE + peer.node_id,) if role == "master" else ()),
        )


def default_path() -> Path:
    return path("network.toml")


class _Section:
    """Typed, checked access to one TOML table; refuses unknown keys."""

    def __init__(self, file: Path, name: str, table: Any, allowed: set[str]):
        if not isinstance(table, dict):
            raise NetworkConfigError(f"{file}: [{name}]: expected a table, got {table!r}")
        unknown = sorted(set(table) - allowed)
        if unknown:
            raise NetworkConfigError(f"{file}: [{name}] {unknown[0]}: unknown key (expected one of {', '.join(sorted(allowed))})")
        self.file, self.name, self.table = file, name, table

    def error(self, key: str, expected: str, value: Any) -> NetworkConfigError:
        return NetworkConfigError(f"{self.file}: [{self.name}] {key}: expected {expected}, got {value!r}")

    def str(self, key: str, default: str, choices: tuple[str, ...] | None = None) -> str:
        v = self.table.get(key, default)
        if not isinstance(v, str) or not v or (choices and v not in choices):
            raise self.error(key, f"one of {', '.join(choices)}" if choices else "a non-empty string", v)
        return v

    def int(self, key: str, default: int, lo: int, hi: int, what: str = "") -> int:
        v = self.table.get(key, default)
        if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
            raise self.error(key, f"an integer in [{lo}, {hi}]{what}", v)
        return v

    def float(self, key: str, default: float, lo: float, hi: float, what: str = "") -> float:
        v = self.table.get(key, default)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not lo <= v <= hi:
            raise self.error(key, f"a number in [{lo:g}, {hi:g}]{what}", v)
        return float(v)

    def bool(self, key: str, default: bool) -> bool:
        v = self.table.get(key, default)
        if not isinstance(v, bool):
            raise self.error(key, "true or false", v)
        return v


def load_network(path: str | Path | None = None) -> NetworkConfig:
    """Load and validate a network settings file (default: bus_config/network.toml)."""
    file = Path(path) if path is not None else default_path()
    try:
        with open(file, "rb") as fh:
            doc = tomllib.load(fh)
    except FileNotFoundError:
        raise NetworkConfigError(f"{file}: no such file (expected a network settings TOML file)") from None
    except OSError as exc:
        raise NetworkConfigError(f"{file}: cannot read ({exc.strerror})") from None
    except tomllib.TOMLDecodeError as exc:
        raise NetworkConfigError(f"{file}: not valid TOML ({exc})") from None

    top = _Section(file, "top level", doc, {"bus", "sync", "heartbeat", "nodes"})
    b = _Section(file, "bus", top.table.get("bus", {}), {"interface", "channel", "bitrate", "options"})
    options = b.table.get("options", {})
    if not isinstance(options, dict):
        raise NetworkConfigError(f"{file}: [bus] options: expected a table of can.Bus keyword arguments, got {options!r}")
    bus = BusConfig(
        interface=b.str("interface", "virtual"),
        channel=b.str("channel", "telethermo"),
        bitrate=b.int("bitrate", 1_000_000, 10_000, 1_000_000),
        options=dict(options),
    )
    s = _Section(file, "sync", top.table.get("sync", {}), {"producer", "period_s", "counter_overflow", "lockstep"})
    overflow = s.int("counter_overflow", 240, 0, 240, " (0 = no counter; 1 is not allowed)")
    if overflow == 1:
        raise s.error("counter_overflow", "0 (no counter) or an integer in [2, 240]", overflow)
    sync = SyncConfig(
        producer=s.str("producer", "master", ("master", "slave", "none")),
        period_s=s.float("period_s", 0.010, 0.0001, 1.0, " s"),
        counter_overflow=overflow,
        lockstep=s.bool("lockstep", True),
    )
    h = _Section(file, "heartbeat", top.table.get("heartbeat", {}), {"producer_ms", "consumer_ms"})
    producer_ms = h.int("producer_ms", 100, 0, 65535, " ms")
    consumer_ms = h.int("consumer_ms", 250, 0, 65535, " ms")
    if consumer_ms and producer_ms and consumer_ms <= producer_ms:
        raise h.error("consumer_ms", f"an integer > producer_ms ({producer_ms}) so that one late heartbeat is not a loss", consumer_ms)
    heartbeat = HeartbeatConfig(producer_ms=producer_ms, consumer_ms=consumer_ms)

    n = _Section(file, "nodes", top.table.get("nodes", {}), set(ROLES))
    nodes: dict[str, NodeConfig] = {}
    defaults = {"master": 1, "slave": 2}
    for role in ROLES:
        t = _Section(file, f"nodes.{role}", n.table.get(role, {}), {"node_id", "eds"})
        eds = Path(t.str("eds", f"{role}.eds"))
        eds = eds if eds.is_absolute() else (file.parent / eds)
        if not eds.is_file():
            raise t.error("eds", f"an existing EDS file (looked for {eds})", t.table.get("eds", f"{role}.eds"))
        nodes[role] = NodeConfig(role, t.int("node_id", defaults[role], 1, 127), eds.resolve())
    if nodes["master"].node_id == nodes["slave"].node_id:
        raise NetworkConfigError(f"{file}: [nodes.slave] node_id: expected a node-ID different from the master's "
                                 f"({nodes['master'].node_id}), got {nodes['slave'].node_id}")
    return NetworkConfig(path=file, bus=bus, sync=sync, heartbeat=heartbeat, nodes=nodes)
