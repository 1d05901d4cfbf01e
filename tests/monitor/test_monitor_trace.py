"""The recorded-trace proof: a trace with every CANopen frame type, produced by real canopen
clients and servers (LocalNodes from bus_config's EDS files), written with can.Logger, read back
with can.LogReader and decoded field by field."""

from __future__ import annotations

import struct
import time

import can
import pytest

from telethermo.monitor import decoder as dec
from telethermo.monitor.record import Recorder
from telethermo.monitor.state import Monitor
from telethermo.nodes.launch import wait_for

from .conftest import CanopenBench, monitor_config

TIME_STAMP = 1_700_000_000.25  # 2023-11-14T22:13:20.250Z


def _wait_heartbeat(b: CanopenBench, node: int, state: int, after: int, timeout_s: float = 20.0) -> int:
    """Wait until the sniffer has a heartbeat of ``node`` in NMT state ``state`` among the frames after
    the first ``after`` (a protocol event instead of a fixed sleep: the heartbeat producers are threads
    that a loaded machine runs late); return the number of frames sniffed by then."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        msgs = list(b.collector.messages)
        if any(m.arbitration_id == 0x700 + node and bytes(m.data) == bytes([state]) for m in msgs[after:]):
            return len(msgs)
        time.sleep(0.01)
    raise AssertionError(f"no heartbeat of node {node} in state 0x{state:02X} within {timeout_s} s")


def make_trace(path) -> dict:
    """Run the scenario on real nodes, log it to ``path``; return what the clients saw."""
    logger = Recorder(path)
    b = CanopenBench(extra_listeners=[logger])
    seen = {}
    try:
        for node in (b.master, b.slave):  # boot-up, then heartbeats (0x1017 = 100 ms)
            node.nmt.state = "INITIALISING"
            node.nmt.state = "PRE-OPERATIONAL"
        b.r_master.sdo["kp_A_per_C"].raw = 1.5  # expedited download
        seen["slave_kp"] = b.r_slave.sdo["kp_A_per_C"].raw  # expedited upload
        seen["device_name"] = b.r_master.sdo[0x1008].raw  # segmented upload
        b.r_slave.sdo.download(0x2200, 0, struct.pack("<f", 2.5), force_segment=True)  # segmented download
        with pytest.raises(Exception, match="0x06010002"):
            b.r_master.sdo["T_sensor_C"].raw = 3.0  # abort: read-only object
        with pytest.raises(Exception, match="0x06020000"):
            b.r_slave.sdo.upload(0x5FFF, 0)  # abort: no such object
        # runtime remapping of the slave's TPDO1 (Q_W first, then estimate_C) by a real client
        b.r_slave.tpdo.read()
        b.r_slave.tpdo[1].clear()
        b.r_slave.tpdo[1].add_variable("Q_W")
        b.r_slave.tpdo[1].add_variable("estimate_C")
        b.r_slave.tpdo[1].save()
        mark = len(b.collector.messages)
        b.client.nmt.state = "OPERATIONAL"  # NMT start, all nodes
        for node in (1, 2):  # heartbeats say OPERATIONAL
            _wait_heartbeat(b, node, 0x05, mark)
        # no settling between the frames this thread sends: the virtual bus queues a frame for the sniffer
        # when it is sent, so the trace holds them in the order sent
        for k in (1, 2, 3):
            b.client.sync.transmit(k)  # SYNC with counter
            b.master.tpdo.read(from_od=True)
            b.master.tpdo[1]["estimate_C"].raw = 33.25 + k
            b.master.tpdo[1]["Q_W"].raw = -0.125 * k
            b.master.tpdo[1].transmit()
            b.slave.tpdo.read()  # the mapping the client wrote
            b.slave.tpdo[1]["estimate_C"].raw = 24.5 + k
            b.slave.tpdo[1]["Q_W"].raw = 0.75 * k
            b.slave.tpdo[1].transmit()
        b.master.emcy.send(0x4210, 0x09, b"\x01\x02\x03\x04\x05")  # EMCY device temperature
        b.client.time.transmit(TIME_STAMP)  # TIME
        b.master.emcy.reset()  # EMCY error reset
        mark = len(b.collector.messages)
        b.r_slave.nmt.state = "STOPPED"  # NMT stop node 2
        b.master.nmt.stop_heartbeat()  # the master reboots (NMT reset node)
        b.r_master.nmt.state = "RESET"
        # the master's server has taken the reset before it boots again (else a late reset would put its
        # restarted heartbeat back to INITIALISING)
        assert wait_for(lambda: b.master.nmt.state == "INITIALISING", 20, poll_s=0.01)
        b.master.nmt.state = "INITIALISING"
        b.master.nmt.state = "PRE-OPERATIONAL"
        _wait_heartbeat(b, 2, 0x04, mark)  # the slave's heartbeat says STOPPED
        mark = _wait_heartbeat(b, 1, 0x00, mark)  # the master's boot-up ...
        _wait_heartbeat(b, 1, 0x7F, mark)  # ... and a heartbeat after it
    finally:
        b.close()
        logger.stop()
    seen["sniffed"] = len(b.collector.messages)
    return seen


@pytest.mark.parametrize("ext", [".log", ".blf"])
def test_recorded_trace_every_frame_type_every_field(tmp_path, ext):
    path = tmp_path / f"trace{ext}"
    seen = make_trace(path)
    msgs = list(can.LogReader(str(path)))
    assert len(msgs) == seen["sniffed"]

    mon = Monitor(monitor_config())
    frames = [mon.feed(m)[0] for m in msgs]
    kinds = {f.kind for f in frames}
    assert {dec.NMT, dec.SYNC, dec.EMCY, dec.TIME, dec.PDO, dec.SDO_REQ, dec.SDO_RESP, dec.HEARTBEAT} <= kinds
    assert mon.stats.unknown_frames == 0 and mon.stats.malformed == 0

    # NMT: broadcast start, stop node 2, reset node 1
    nmt = [(f.fields["command_name"], f.fields["target"]) for f in frames if f.kind == dec.NMT]
    assert nmt == [("start", 0), ("stop", 2), ("reset node", 1)]

    # SYNC with its counter, never mistaken for EMCY (0x080 vs 0x081..0x0FF)
    syncs = [f for f in frames if f.kind == dec.SYNC]
    assert [f.fields["counter"] for f in syncs] == [1, 2, 3]
    assert all(f.cob_id == 0x080 for f in syncs)
    assert mon.stats.syncs == 3 and mon.stats.sync_counter_errors == 0

    # EMCY: code, class text, register bits, manufacturer bytes; then the error reset
    emcys = [f for f in frames if f.kind == dec.EMCY]
    assert len(emcys) == 2 and all(f.node == 1 and f.cob_id == 0x081 for f in emcys)
    e = emcys[0].fields
    assert e["code"] == 0x4210 and e["code_text"] == "Device temperature"
    assert e["register"] == 0x09 and e["register_bits"] == ["generic", "temperature"]
    assert e["manufacturer"] == "0102030405" and not e["reset"]
    assert emcys[1].fields["code"] == 0 and emcys[1].fields["reset"]
    assert mon.nodes[1].emcys == 2 and mon.nodes[1].last_emcy["code"] == 0x4210  # the last error...
    assert not mon.nodes[1].emcy_active and mon.nodes[1].error_register == 0  # ...since reset

    # TIME: days since 1984 and ms after midnight of the stamp the producer was given
    (tf,) = [f for f in frames if f.kind == dec.TIME]
    assert tf.fields["iso"] == "2023-11-14T22:13:20.250+00:00"

    # PDOs: master TPDO1 by the EDS mapping, slave TPDO1 by the remapping seen on the bus
    pdos = [f for f in frames if f.kind == dec.PDO]
    m_pdo = [f for f in pdos if f.node == 1]
    s_pdo = [f for f in pdos if f.node == 2]
    assert [[(v["name"], v["value"], v["unit"]) for v in f.fields["values"]] for f in m_pdo] == [
        [("estimate_C", 33.25 + k, "degC"), ("Q_W", -0.125 * k, "W")] for k in (1, 2, 3)
    ]
    assert [[(v["name"], v["value"], v["unit"]) for v in f.fields["values"]] for f in s_pdo] == [
        [("Q_W", 0.75 * k, "W"), ("estimate_C", 24.5 + k, "degC")] for k in (1, 2, 3)
    ]
    assert all(f.cob_id == 0x181 for f in m_pdo) and all(f.cob_id == 0x182 for f in s_pdo)
    remaps = [ev for ev in mon.log.events if ev.kind == "pdo_remap"]
    assert remaps and all(ev.node == 2 for ev in remaps)

    # SDO: one state machine per node; every transfer with name, value, unit, mode and abort text
    tr1 = list(mon.nodes[1].sdo_transfers)
    by = {
        (r.transfer.node, r.transfer.direction, r.transfer.index, r.transfer.subindex, r.transfer.status): r
        for r in tr1
    }
    kp = by[(1, "download", 0x2200, 0, "ok")]
    assert (kp.name, kp.value, kp.unit, kp.transfer.mode) == ("kp_A_per_C", 1.5, "A/degC", "expedited")
    name = by[(1, "upload", 0x1008, 0, "ok")]
    assert name.value == seen["device_name"] and name.transfer.mode == "segmented"
    assert name.transfer.size == len(seen["device_name"]) == len(name.transfer.data)
    ab = by[(1, "download", 0x2000, 0, "aborted")]
    assert ab.transfer.abort_code == 0x06010002
    assert (
        ab.transfer.abort_text == "Attempt to write a read only object" and ab.transfer.aborted_by == "server"
    )
    assert [r.name for r in tr1].count("T_sensor_C") == 1
    all2 = [r for f in frames if f.node == 2 and "transfer" in f.fields for r in [f.fields["transfer"]]]
    s_kp_read = next(t for t in all2 if t["direction"] == "upload" and t["index"] == 0x2200)
    assert s_kp_read["value"] == pytest.approx(seen["slave_kp"], abs=0) and s_kp_read["mode"] == "expedited"
    s_seg = next(t for t in all2 if t["direction"] == "download" and t["index"] == 0x2200)
    assert (s_seg["mode"], s_seg["value"], s_seg["status"], s_seg["size"]) == ("segmented", 2.5, "ok", 4)
    s_abort = next(t for t in all2 if t["status"] == "aborted")
    assert (s_abort["index"], s_abort["abort_code"], s_abort["abort_text"]) == (
        0x5FFF,
        0x06020000,
        "Object does not exist in the object dictionary",
    )
    assert mon.nodes[1].sdo_aborts == 1 and mon.nodes[2].sdo_aborts == 1
    assert mon.log.counts["WARN"] >= 2  # the two aborts (events with severity)

    # heartbeats: states in order, boot-ups, and the period statistics from the trace's own stamps
    hb1 = [f.fields["state_name"] for f in frames if f.kind == dec.HEARTBEAT and f.node == 1]
    hb2 = [f.fields["state_name"] for f in frames if f.kind == dec.HEARTBEAT and f.node == 2]
    assert hb1[0] == "INITIALISING" and hb1.count("INITIALISING") == 2  # boot-up, reboot
    assert "OPERATIONAL" in hb1 and hb1[-1] == "PRE-OPERATIONAL"
    assert hb2[0] == "INITIALISING" and hb2[-1] == "STOPPED" and "OPERATIONAL" in hb2
    assert mon.nodes[1].boot_ups == 2 and mon.nodes[2].boot_ups == 1
    assert mon.nodes[1].nmt_state == "PRE-OPERATIONAL" and mon.nodes[2].nmt_state == "STOPPED"
    unexpected = [ev for ev in mon.log.events if ev.kind == "boot_up" and ev.severity != "INFO"]
    assert unexpected == []  # the reboot followed an NMT reset: expected
    t2 = [m.timestamp for m in msgs if m.arbitration_id == 0x702]
    gaps = [b - a for a, b in zip(t2[1:], t2[2:])]  # from the first heartbeat after the boot-up
    assert mon.nodes[2].hb_period_min_s == pytest.approx(min(gaps), abs=1e-9)
    assert mon.nodes[2].hb_period_max_s == pytest.approx(max(gaps), abs=1e-9)
    assert mon.nodes[2].consumer_time_s == pytest.approx(0.250)  # master's 0x1016 watches node 2
    assert mon.nodes[1].producer_time_s == pytest.approx(0.100)
