"""A synthesised realistic mix of the telethermo pair's traffic at a 1 ms SYNC period, and the monitor
configuration for it from the shipped EDS files: the monitor benchmarks' traffic (bench/monitor_bench.py,
bench/monitor_hub.py) and the tests'."""

from __future__ import annotations

import struct

import can
from canopen.objectdictionary import import_od

from telethermo.device.netconfig import load_network
from telethermo.monitor.records import MonitorConfig, NodeInfo
from telethermo.remote.targets import node_targets

PERIOD_S = 0.001


def traffic(n_frames: int) -> list[can.Message]:
    """``n_frames`` frames of the mix described in the module docstring."""
    out: list[can.Message] = []
    t, k = 1_700_000_000.0, 0

    def add(dt: float, cob: int, data: bytes) -> None:
        out.append(can.Message(timestamp=t + dt, arbitration_id=cob, data=data, is_extended_id=False))

    add(0.0, 0x701, b"\x05")
    add(0.0, 0x702, b"\x05")
    while len(out) < n_frames:
        k += 1
        t += PERIOD_S
        add(0.0, 0x080, bytes([(k - 1) % 240 + 1]))
        add(0.0001, 0x181, struct.pack("<ff", 30.0 + 1e-4 * (k % 1000), -0.5))
        add(0.0002, 0x182, struct.pack("<ff", 24.0, 0.5))
        add(0.0003, 0x681, b"\x01")
        add(0.0004, 0x682, b"\x01\x00\x00\x00\x00\x00\x00\x00")  # slave TPDO5: contact + identification
        if k % 100 == 0:
            add(0.0005, 0x701, b"\x05")
            add(0.0005, 0x702, b"\x05")
            add(0.0006, 0x601, struct.pack("<BHB4x", 0x40, 0x1017, 0))
            add(0.0007, 0x581, struct.pack("<BHBL", 0x4B, 0x1017, 0, 100))
        if k % 1000 == 500:
            add(0.0008, 0x082, struct.pack("<HB5s", 0x4210, 0x09, bytes(5)))
            add(0.0009, 0x082, bytes(8))
    return out[:n_frames]


def monitor_config() -> MonitorConfig:
    """Both shipped nodes by their EDS, 1 Mbit/s, the 1 ms period of the traffic."""
    nodes = {
        t.node_id: NodeInfo(t.role, import_od(str(t.eds), t.node_id)) for t in node_targets(load_network())
    }
    return MonitorConfig(nodes=nodes, bitrate_bps=1_000_000, sync_period_s=PERIOD_S)
