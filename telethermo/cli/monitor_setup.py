"""The monitor's view of the network (``telethermo monitor`` and ``telethermo record``): node names and
EDS dictionaries with the network file's power-on overrides. Apart from :mod:`telethermo.cli.common` so
that the SDO commands do not import the monitor's decoders; the nodes are named as every command names
them (:mod:`telethermo.remote.targets`)."""
from __future__ import annotations

from canopen.objectdictionary import import_od

from telethermo.device.netconfig import NetworkConfig, NetworkConfigError
from telethermo.cli.main import UserError
from telethermo.monitor.records import MonitorConfig, NodeInfo
from telethermo.remote.targets import node_targets


def monitor_config(net: NetworkConfig, *, bitrate: int | None = None, sync_period_s: float | None = None
                   ) -> MonitorConfig:
    """The monitor's view of the network: node names, EDS dictionaries with the network file's
    power-on overrides (heartbeat and consumer times, SYNC), bitrate and SYNC period (real time only)."""
    nodes = {}
    for t in node_targets(net):
        if t.eds is None:   # another device named without an EDS: known by name, its PDOs not decoded
            nodes[t.node_id] = NodeInfo(t.role, None)
            continue
        try:
            od = import_od(str(t.eds), t.node_id)
        except Exception as exc:  # canopen raises assorted errors for a bad EDS
            raise UserError(f"{t.eds}: cannot parse EDS ({exc})") from None
        try:
            for (index, sub), value in net.device_settings(t.role).overrides().items():
                obj = od[index]
                var = obj if sub == 0 and not hasattr(obj, "subindices") else obj[sub]
                var.value = value
        except (KeyError, NetworkConfigError):
            pass  # an override for an object this EDS lacks: keep the EDS value
        nodes[t.node_id] = NodeInfo(t.role, od)
    period = sync_period_s if sync_period_s is not None else (None if net.sync.lockstep else net.sync.period_s)
    return MonitorConfig(nodes=nodes, bitrate_bps=bitrate or net.bus.bitrate, sync_period_s=period)
