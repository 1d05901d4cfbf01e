"""The monitor says how the pair is paced from what the bus shows, never from the network file (issue 25:
a real-time pair was labelled "lockstep" because the shipped network.toml says ``lockstep = true``).
The shipped network file is used throughout, so the file always says lockstep."""

from __future__ import annotations

import time
import warnings

import can
import canopen

from telethermo.cli.monitor_setup import monitor_config
from telethermo.device.device import Device
from telethermo.device.netconfig import load_network
from telethermo.monitor.state import Monitor
from telethermo.monitor.view import ViewState, render_lines


def sync(t: float, k: int) -> can.Message:
    return can.Message(timestamp=t, arbitration_id=0x080, data=bytes([k % 240 + 1]), is_extended_id=False)


def sdo(frames: list[str]) -> list[str]:
    """The SDO frames (COB-ID 0x580/0x600 + node) of ``"ID:hex"`` strings."""
    return [f for f in frames if f[0] in "56"]


def shipped_monitor() -> Monitor:
    net = load_network()
    assert net.sync.lockstep and net.sync.period_s == 0.010  # what the file claims
    return Monitor(monitor_config(net))


def rates_line(mon: Monitor) -> str:
    return render_lines(mon, ViewState(), 300, 5)[1]


def test_syncs_at_the_period_are_real_time_whatever_the_file_says():
    mon = shipped_monitor()
    for k in range(30):
        mon.feed(sync(100.0 + 0.010 * k + (0.0004 if k % 3 else 0.0), k))
    snap = mon.snapshot()
    assert snap["network_file_lockstep"] is True and snap["sync_lockstep"] is False
    assert snap["sync_timing_evidence"].startswith("SYNC every 10.00 ms, the nominal period")
    assert "(nominal 10.00, real time)" in rates_line(mon) and "lockstep" not in rates_line(mon)


def test_syncs_much_faster_than_the_period_are_lockstep():
    mon = shipped_monitor()
    for k in range(30):
        mon.feed(sync(100.0 + 0.003 * k, k))
    assert mon.snapshot()["sync_lockstep"] is True and "(nominal 10.00, lockstep)" in rates_line(mon)


def test_too_few_or_ambiguous_syncs_are_unknown():
    mon = shipped_monitor()
    for k in range(10):
        mon.feed(sync(100.0 + 0.010 * k, k))
    assert mon.snapshot()["sync_lockstep"] is None and "(nominal 10.00, timing unknown)" in rates_line(mon)
    mon = shipped_monitor()
    for k in range(30):  # 25 ms against 10 ms: a slow lockstep pair or late real-time cycles
        mon.feed(sync(100.0 + 0.025 * k, k))
    snap = mon.snapshot()
    assert snap["sync_lockstep"] is None and "late real-time cycles" in snap["sync_timing_evidence"]


def test_a_nodes_own_lockstep_object_read_by_canopens_client_decides():
    """A real device (EDS, canopen LocalNode) answers canopen's SdoClient for `lockstep` (0x2704); the monitor
    on the same bus takes the node's word over SYNC timing that looks like the other mode."""
    channel = f"tt-mon-timing-{time.monotonic_ns()}"
    net = load_network()
    nw = canopen.Network()
    nw.NOTIFIER_CYCLE = 0.05
    nw.connect(interface="virtual", channel=channel)
    cfg = net.node("master")
    dev = Device(nw, cfg.node_id, cfg.eds, settings=net.device_settings("master"))
    dev.start()
    client_nw = canopen.Network()
    client_nw.NOTIFIER_CYCLE = 0.05
    client_nw.connect(interface="virtual", channel=channel)
    listener = can.Bus(interface="virtual", channel=channel)
    try:
        node = client_nw.add_node(cfg.node_id, str(cfg.eds))
        value = node.sdo["lockstep"].raw  # canopen's own client, by the EDS name
        mon = shipped_monitor()
        for k in range(30):  # SYNC timing alone would say the other mode
            mon.feed(sync(100.0 + (0.010 if value else 0.003) * k, k))
        assert mon.timing.verdict(mon.stats.sync_intervals_s, 0.010)[0] is (not value)
        seen: list[str] = []
        # the first read once went unseen beside two CPU hogs in the full suite (not reproduced alone): each
        # read is a new chance, and one that needed another says so in the test's warnings with what was seen
        for attempt in range(3):
            if attempt:
                warnings.warn(f"lockstep upload not seen by the monitor; SDO frames so far: {sdo(seen)}")
                assert node.sdo["lockstep"].raw == value
            t_end = time.monotonic() + 5.0
            while time.monotonic() < t_end and not mon.timing.by_node:
                m = listener.recv(0.1)
                if m is not None:
                    seen.append(f"{m.arbitration_id:03X}:{m.data.hex()}")
                    mon.feed(m)
            if mon.timing.by_node:
                break
        assert mon.timing.by_node, f"the monitor never saw the lockstep upload; SDO frames seen: {sdo(seen)}"
        snap = mon.snapshot()
        assert snap["sync_lockstep"] is bool(value)
        assert snap["sync_timing_evidence"] == (
            f"the nodes' lockstep object: node {cfg.node_id} {'lockstep' if value else 'real time'} (SDO)"
        )
    finally:
        listener.shutdown()
        client_nw.disconnect()
        dev.close()
        nw.disconnect()
