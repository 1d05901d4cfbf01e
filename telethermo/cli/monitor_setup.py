"""The monitor's view of the network (``telethermo monitor`` and ``telethermo record``): node names and
EDS dictionaries with the network file's power-on overrides. Apart from :mod:`telethermo.cli.common` so
that the SDO commands do not import the monitor's decoders; the nodes are named as every command names
them (:mod:`telethermo.remote.targets`). Every EDS is read by the one loader `get`, `set` and the nodes use
(:class:`telethermo.device.eds_info.EdsInfo`, CiA 306 checks) before canopen builds the dictionary from it:
a file they refuse, the monitor refuses with the same words."""

from __future__ import annotations

from pathlib import Path

from canopen.objectdictionary import import_od

from telethermo.device.eds_info import EdsError, EdsInfo
from telethermo.device.netconfig import NetworkConfig, NetworkConfigError
from telethermo.cli.main import UserError
from telethermo.iomodule.rigconfig import RigConfigError, load_rig_config
from telethermo.monitor.records import MonitorConfig, NodeInfo
from telethermo.remote.targets import eds_info, node_targets


def monitor_config(
    net: NetworkConfig,
    *,
    bitrate: int | None = None,
    sync_period_s: float | None = None,
    extra_eds: list[str] | tuple[str, ...] = (),
    rig_configs: list[str] | tuple[str, ...] = (),
) -> MonitorConfig:
    """The monitor's view of the network: node names, EDS dictionaries (``extra_eds``: ``NODE=FILE`` of
    further nodes, named by the file; ``rig_configs``: RIG.toml files, whose I/O modules are named and
    decoded by their EDS and whose controller beats at the period it lowers its heartbeat to) with the
    network file's
    power-on overrides (heartbeat and consumer times, SYNC), bitrate and the nominal SYNC period
    (``sync_period_s``, else the network file's, in lockstep too: late cycles are then counted
    against the period the nodes were configured with, and the view says "lockstep")."""
    nodes = {}
    for t in node_targets(net):
        if t.eds is None:  # another device named without an EDS: known by name, its PDOs not decoded
            nodes[t.node_id] = NodeInfo(t.role, None)
            continue
        eds_info(t)  # the check `get` and the nodes make (UserError naming the file and what is wrong)
        od = _import_od(t.eds, t.node_id)
        _apply_overrides(net, t.role, od)
        nodes[t.node_id] = NodeInfo(t.role, od)
    for spec in extra_eds:
        node_id, info = _extra_node(spec)
        if node_id in nodes:
            raise UserError(
                f"--eds {spec}: node {node_id} is the network file's {nodes[node_id].name}, "
                f"whose EDS is {net.nodes[nodes[node_id].name].eds}"
            )
        nodes[node_id] = info
    for path in rig_configs:
        _add_rig(net, nodes, path)
    period = sync_period_s if sync_period_s is not None else net.sync.period_s
    return MonitorConfig(
        nodes=nodes,
        bitrate_bps=bitrate or net.bus.bitrate,
        sync_period_s=period,
        sync_lockstep=net.sync.lockstep,
    )


def _extra_node(spec: str) -> tuple[int, NodeInfo]:
    """``NODE=FILE`` (``--eds``): a node outside the network file, named by its EDS file's stem."""
    node, sep, path = spec.partition("=")
    try:
        node_id = int(node, 0)
    except ValueError:
        node_id = 0
    if not sep or not path or not 1 <= node_id <= 127:
        raise UserError(f"--eds {spec!r}: expected NODE=FILE with NODE a node-ID 1..127, e.g. 5=arm.eds")
    eds = Path(path)
    if not eds.is_file():
        raise UserError(f"--eds {spec}: {eds}: no such EDS file")
    return node_id, NodeInfo(eds.stem, _checked_od(eds, node_id, f"--eds {spec}"))


def _add_rig(net: NetworkConfig, nodes: dict[int, NodeInfo], path: str) -> None:
    """``--rig-config RIG.toml``: its modules by name and EDS; its controller's heartbeat period lowered as
    the node lowers it (:attr:`RigConfig.heartbeat_limit_ms`), so the monitor expects what the node does."""
    try:
        rig = load_rig_config(path)
    except RigConfigError as exc:
        raise UserError(f"--rig-config: {exc}") from None
    for name, module in rig.modules.items():
        if module.node_id in nodes:
            raise UserError(
                f"--rig-config {path}: module {name} is node {module.node_id}, "
                f"which is already {nodes[module.node_id].name}"
            )
        where = f"--rig-config {path}: module {name}"
        nodes[module.node_id] = NodeInfo(name, _checked_od(module.eds, module.node_id, where))
    controller = net.nodes.get(rig.controller) if rig.controller else None
    info = nodes.get(controller.node_id) if controller is not None else None
    if info is None or info.od is None:
        return
    try:
        var = info.od[0x1017]
    except KeyError:
        return
    var.value = rig.controller_heartbeat_ms(int(var.value or 0))


def _checked_od(eds: Path, node_id: int, where: str):
    """canopen's dictionary of ``eds`` after the check `get` and the nodes make (UserError: ``where``)."""
    try:
        EdsInfo(eds)
    except EdsError as exc:
        raise UserError(f"{where}: {exc}") from None
    return _import_od(eds, node_id)


def _import_od(eds: Path, node_id: int):
    """canopen's dictionary of an EDS that :class:`EdsInfo` accepted."""
    try:
        return import_od(str(eds), node_id)
    except Exception as exc:  # canopen raises assorted errors for a bad EDS
        raise UserError(f"{eds}: cannot parse EDS ({' '.join(str(exc).split())})") from None


def _apply_overrides(net: NetworkConfig, role: str, od) -> None:
    """Write the network file's power-on values (0x1016 consumer and 0x1017 producer heartbeat times,
    SYNC) into the node's dictionary, as the node does at start; one the EDS lacks keeps the EDS value."""
    try:
        overrides = net.device_settings(role).overrides()
    except (KeyError, NetworkConfigError):
        return  # a node without device settings in the file (a further node): its EDS values
    for (index, sub), value in overrides.items():
        try:
            obj = od[index]
            var = obj if sub == 0 and not hasattr(obj, "subindices") else obj[sub]
        except KeyError:
            continue
        var.value = value
