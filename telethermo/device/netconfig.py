"""The network settings file (bus_config/network.toml): load, validate, and turn into device settings.

Every field is checked; a bad file raises :class:`NetworkConfigError` whose message names the file,
the field (``[section] key``) and what was expected, e.g.::

    bus_config/network.toml: [heartbeat] consumer_ms: expected an integer > producer_ms (100), got 80
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from telethermo.device.settings import DeviceSettings
from telethermo.inputfile import InputFileError, Section, load_toml
from telethermo.bus_config import path
from telethermo.bus_config.edsgen import CONTACT_PDO_BASE, IDENT_PDO_BASE

ROLES = ("master", "slave")


class NetworkConfigError(InputFileError):
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
    """A node of the network file: ``master`` and ``slave`` (this system's pair, EDS required) or another
    device on the same bus (a robot arm, I/O modules, a thermocouple amplifier: ``eds`` optional)."""

    role: str
    node_id: int
    eds: Path | None


#: names of other nodes: lower-case, a letter first (they become CLI words: telethermo get arm 0x1018:1)
OTHER_NODE_NAME = re.compile(r"[a-z][a-z0-9_-]{0,31}")


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
            raise NetworkConfigError(
                f"{self.path}: [nodes.{role}]: no such node (have {', '.join(self.nodes)})"
            )
        return self.nodes[role]

    def peer(self, role: str) -> NodeConfig:
        """The other node of the pair (master and slave only: another device on the bus has no peer here)."""
        self.node(role)
        if role not in ROLES:
            raise NetworkConfigError(
                f"{self.path}: [nodes.{role}]: not one of the pair (master, slave): no peer"
            )
        return self.node("slave" if role == "master" else "master")

    def device_settings(self, role: str) -> DeviceSettings:
        """Power-on settings of ``role``'s device: heartbeat times, SYNC role/period/counter, peers."""
        peer = self.peer(role)
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
    return Path(path("network.toml"))  # typed Path also where mypy cannot resolve telethermo.bus_config


def load_network(path: str | Path | None = None) -> NetworkConfig:
    """Load and validate a network settings file (default: bus_config/network.toml)."""
    file = Path(path) if path is not None else default_path()
    doc = load_toml(file, NetworkConfigError, "a network settings TOML file")
    top = Section(file, "", doc, {"bus", "sync", "heartbeat", "nodes"}, error=NetworkConfigError)
    b = top.table("bus", {"interface", "channel", "bitrate", "options"}, {})
    options = b.table("options", None, {}, "a table of can.Bus keyword arguments")
    bus = BusConfig(
        interface=b.str("interface", "virtual"),
        channel=b.str("channel", "telethermo"),
        bitrate=b.int("bitrate", 1_000_000, 10_000, 1_000_000),
        options=dict(options.raw),
    )
    s = top.table("sync", {"producer", "period_s", "counter_overflow", "lockstep"}, {})
    overflow = s.int("counter_overflow", 240, 0, 240, " (0 = no counter; 1 is not allowed)")
    if overflow == 1:
        raise s.fail("counter_overflow", "0 (no counter) or an integer in [2, 240]", overflow)
    sync = SyncConfig(
        producer=s.str("producer", "master", ("master", "slave", "none")),
        period_s=s.float("period_s", 0.010, 0.0001, 1.0, " s"),
        counter_overflow=overflow,
        lockstep=s.bool("lockstep", True),
    )
    h = top.table("heartbeat", {"producer_ms", "consumer_ms"}, {})
    producer_ms = h.int("producer_ms", 100, 0, 65535, " ms")
    consumer_ms = h.int("consumer_ms", 250, 0, 65535, " ms")
    if consumer_ms and producer_ms and consumer_ms <= producer_ms:
        raise h.fail(
            "consumer_ms",
            f"an integer > producer_ms ({producer_ms}) so that one late heartbeat is not a loss",
            consumer_ms,
        )
    heartbeat = HeartbeatConfig(producer_ms=producer_ms, consumer_ms=consumer_ms)

    table = top.table("nodes", None, {})
    nodes = _pair(file, table)
    for name, t in table.raw.items():
        if name not in ROLES:
            nodes[name] = _other_node(file, name, t, nodes)
    return NetworkConfig(path=file, bus=bus, sync=sync, heartbeat=heartbeat, nodes=nodes)


def _eds_path(file: Path, t: Section, default: str | None) -> Path | None:
    """The node's EDS (relative to the network file), checked to exist; None when optional and not given."""
    given = t.raw.get("eds", default)
    if given is None:
        return None
    eds = Path(t.str("eds", default or ""))  # given is not None: a table entry or a default
    eds = eds if eds.is_absolute() else (file.parent / eds)
    if not eds.is_file():
        raise t.fail("eds", f"an existing EDS file (looked for {eds})", given)
    return eds.resolve()


def _pair(file: Path, table: Section) -> dict[str, NodeConfig]:
    """[nodes.master] and [nodes.slave]: this system's two nodes (defaults: node-IDs 1 and 2,
    the shipped EDS)."""
    nodes: dict[str, NodeConfig] = {}
    defaults = {"master": 1, "slave": 2}
    for role in ROLES:
        t = table.table(role, {"node_id", "eds"}, {})
        nodes[role] = NodeConfig(
            role, t.int("node_id", defaults[role], 1, 127), _eds_path(file, t, f"{role}.eds")
        )
    if nodes["master"].node_id == nodes["slave"].node_id:
        raise NetworkConfigError(
            f"{file}: [nodes.slave] node_id: expected a node-ID different from the master's "
            f"({nodes['master'].node_id}), got {nodes['slave'].node_id}"
        )
    return nodes


def _other_node(file: Path, name: str, raw: Any, nodes: dict[str, NodeConfig]) -> NodeConfig:
    """[nodes.NAME]: another device on the bus: node_id required, eds optional."""
    if not OTHER_NODE_NAME.fullmatch(name):
        raise NetworkConfigError(
            f"{file}: [nodes.{name}]: expected a node name of lower-case letters, digits, "
            "'_' or '-', starting with a letter"
        )
    t = Section(
        file,
        f"nodes.{name}",
        raw,
        {"node_id", "eds"},
        error=NetworkConfigError,
        expected="a table (node_id, eds)",
    )
    if "node_id" not in raw:
        raise NetworkConfigError(
            f"{file}: [nodes.{name}] node_id: missing (a node other than master and slave "
            "needs its node-ID, an integer in [1, 127])"
        )
    node_id = t.int("node_id", 0, 1, 127)
    for other in nodes.values():
        if other.node_id == node_id:
            raise t.fail("node_id", f"a node-ID not used by [nodes.{other.role}] ({node_id})", node_id)
    return NodeConfig(name, node_id, _eds_path(file, t, None))
