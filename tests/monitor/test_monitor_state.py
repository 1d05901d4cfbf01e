"""The monitor's bus state from frames with known timestamps: heartbeat timing against the
consumer time, NMT states, SYNC period/jitter and late cycles, missed PDOs, bus load, remapping."""

from __future__ import annotations

import statistics
import struct

import can
import pytest

from telethermo.monitor import decoder as dec
from telethermo.monitor.busload import message_length_bits
from telethermo.monitor.state import Monitor

from .conftest import monitor_config


def msg(t, cob, data=b"", **kw):
    return can.Message(timestamp=t, arbitration_id=cob, data=bytes(data), is_extended_id=False, **kw)


def feed(mon, *msgs):
    out = []
    for m in msgs:
        out += mon.feed(m)[1]
    return out


def test_classification_sync_emcy_time_pdo_sdo_heartbeat():
    c = dec.classify
    assert c(0x080) == (dec.SYNC, None)
    assert c(0x081) == (dec.EMCY, 1) and c(0x0FF) == (dec.EMCY, 127)
    assert c(0x100) == (dec.TIME, None)
    assert c(0x000) == (dec.NMT, None)
    assert c(0x181) == (dec.PDO, 1) and c(0x57F) == (dec.PDO, 127)
    assert c(0x581) == (dec.SDO_RESP, 1) and c(0x601) == (dec.SDO_REQ, 1)
    assert c(0x705) == (dec.HEARTBEAT, 5) and c(0x705, remote=True) == (dec.NODE_GUARD, 5)
    assert c(0x7E5) == (dec.LSS, None) and c(0x7F0) == (dec.UNKNOWN, None)
    assert c(0x090, sync_cob_id=0x090) == (dec.SYNC, None)  # SYNC COB-ID from 0x1005
    assert c(0x0A5, pdo_cob_ids={0x0A5})[0] == dec.PDO  # a configured PDO beats the range guess
    assert c(0x080, error=True) == (dec.ERROR_FRAME, None)


def test_heartbeat_period_timeout_against_consumer_time_and_return():
    mon = Monitor(monitor_config())
    assert mon.nodes[2].nmt_state == "unknown" and mon.nodes[2].consumer_time_s == pytest.approx(0.25)
    feed(
        mon,
        msg(10.0, 0x702, [0x00]),
        msg(10.001, 0x702, [0x7F]),
        msg(10.101, 0x702, [0x7F]),
        msg(10.203, 0x702, [0x05]),
        msg(10.300, 0x702, [0x05]),
    )
    st = mon.nodes[2]
    assert st.boot_ups == 1 and st.nmt_state == "OPERATIONAL"
    assert st.hb_period_min_s == pytest.approx(0.097) and st.hb_period_max_s == pytest.approx(0.102)
    assert mon.tick(10.549) == []  # 249 ms of silence: within 250 ms
    (lost,) = mon.tick(10.551)
    assert (lost.kind, lost.severity, lost.node) == ("heartbeat_lost", "ERROR", 2)
    assert mon.tick(11.0) == [] and st.hb_lost and st.hb_losses == 1  # reported once
    ev = feed(mon, msg(11.1, 0x702, [0x05]))
    assert [e.kind for e in ev] == ["heartbeat_back"] and not st.hb_lost


def test_a_node_the_settings_do_not_name_is_watched_at_twice_its_measured_period():
    # a lab's CiA 401 module (node 9, in no network file) beats every 100 ms: killed, it must show as lost
    mon = Monitor(monitor_config())
    feed(mon, *(msg(20.0 + 0.1 * k, 0x709, [0x05]) for k in range(3)))
    assert mon.nodes[9].hb_timeout_s is None  # three beats: not yet a period to trust
    assert mon.tick(21.0) == []
    feed(mon, msg(21.05, 0x709, [0x05]), msg(21.15, 0x709, [0x05]))  # longest period now 0.85 s (a gap)
    st = mon.nodes[9]
    assert st.hb_timeout_s == pytest.approx(2 * 0.85) and st.hb_timeout_from == "measured period"
    assert mon.tick(21.15 + 1.69) == []
    (lost,) = mon.tick(21.15 + 1.71)
    assert (lost.kind, lost.node) == ("heartbeat_lost", 9) and "measured period 1700 ms" in lost.text
    assert st.hb_lost and mon.tick(30.0) == []


def test_unexpected_boot_up_is_a_warning_but_one_after_nmt_reset_is_not():
    mon = Monitor(monitor_config())
    feed(mon, msg(0.0, 0x701, [0x00]), msg(0.1, 0x701, [0x05]))
    (ev,) = feed(mon, msg(0.2, 0x701, [0x00]))
    assert (ev.kind, ev.severity) == ("boot_up", "WARN")
    ev = feed(mon, msg(0.3, 0x701, [0x05]), msg(0.4, 0x000, [0x81, 1]), msg(0.5, 0x701, [0x00]))
    assert [(e.kind, e.severity) for e in ev] == [("nmt_state", "INFO"), ("nmt", "INFO"), ("boot_up", "INFO")]
    assert mon.nodes[1].boot_ups == 3


def test_sync_period_jitter_counter_and_late_cycles():
    mon = Monitor(monitor_config(sync_period_s=0.010, late_tolerance=0.5))
    ts = [0.0, 0.010, 0.021, 0.030, 0.046, 0.056]
    evs = feed(mon, *[msg(t, 0x080, [k + 1]) for k, t in enumerate(ts)])
    iv = [b - a for a, b in zip(ts, ts[1:])]
    summ = mon.stats.sync_summary()
    assert summ["period_s"] == pytest.approx(statistics.fmean(iv))
    assert summ["jitter_s"] == pytest.approx(statistics.pstdev(iv))
    assert (summ["min_s"], summ["max_s"]) == (pytest.approx(0.009), pytest.approx(0.016))
    assert mon.stats.late_cycles == 1 and [e.kind for e in evs] == ["late_cycle"]
    # more late cycles within a second: all counted, no new event; the next event a second later
    # says how many it stands for
    evs = feed(
        mon, msg(0.076, 0x080, [7]), msg(0.096, 0x080, [8]), msg(0.106, 0x080, [9]), msg(0.126, 0x080, [10])
    )
    assert mon.stats.late_cycles == 4 and evs == []
    evs = feed(mon, msg(1.126, 0x080, [11]))
    assert [e.fields["late_since_last_event"] for e in evs] == [4]
    (jump,) = feed(mon, msg(1.136, 0x080, [19]))
    assert jump.kind == "sync_counter" and mon.stats.sync_counter_errors == 1
    assert feed(mon, msg(1.146, 0x080, [1])) == []  # wrap-around to 1 is normal


def test_missing_sync_pdo_from_an_operational_node_is_counted():
    mon = Monitor(monitor_config())
    pdo = struct.pack("<ff", 33.0, 0.5)
    feed(
        mon,
        msg(0.0, 0x701, [0x05]),
        msg(0.01, 0x080, [1]),
        msg(0.011, 0x181, pdo),
        msg(0.012, 0x681, [0]),
        msg(0.02, 0x080, [2]),
        msg(0.021, 0x181, pdo),
        msg(0.022, 0x681, [1]),
    )
    assert mon.stats.missed_pdos == 0
    evs = feed(mon, msg(0.03, 0x080, [3]), msg(0.04, 0x080, [4]), msg(0.05, 0x080, [5]))
    assert mon.stats.missed_pdos == 4  # cycles 3 and 4 had no TPDO1, no TPDO5
    assert [e.kind for e in evs] == ["pdo_missing"] * 2  # one event per PDO per outage, not per cycle
    # a stopped node is not expected to send PDOs
    feed(
        mon,
        msg(0.051, 0x000, [0x02, 1]),
        msg(0.06, 0x080, [6]),
        msg(0.07, 0x701, [0x04]),
        msg(0.08, 0x080, [7]),
    )
    assert (
        mon.stats.missed_pdos == 4
    )  # the NMT stop disarms the cycle it falls in, STOPPED ones are not armed


def test_bus_load_is_stuffed_bits_over_bitrate_and_window():
    mon = Monitor(monitor_config(bitrate_bps=125_000, window_s=1.0))
    msgs = [msg(0.1 * k, 0x181, struct.pack("<ff", 30.0 + k, -1.0)) for k in range(11)]
    feed(mon, *msgs)
    bits = sum(message_length_bits(m) for m in msgs[1:])  # the window (0, 1.0] at t = 1.0
    assert mon.stats.bus_load == pytest.approx(bits / 125_000 / 1.0)
    assert mon.stats.frames_per_s == pytest.approx(10.0)
    mon.tick(3.0)
    assert mon.stats.frames_per_s == 0.0 and mon.stats.bus_load == 0.0  # a silent bus reads zero


def test_emcy_and_pdo_length_and_malformed_frames():
    mon = Monitor(monitor_config())
    (ev,) = feed(mon, msg(0.0, 0x082, struct.pack("<HB5s", 0x8130, 0x11, b"\x02\x00\x00\x00\x00")))
    assert ev.severity == "ERROR" and ev.fields["code_text"] == "Life guard error or heartbeat error"
    assert ev.fields["register_bits"] == ["generic", "communication"]
    (ev,) = feed(mon, msg(0.1, 0x181, b"\x00\x00\x04\x42"))  # 4 bytes where 8 are mapped
    assert ev.kind == "pdo_length"
    (ev,) = feed(mon, msg(0.2, 0x701, b"\x05\x00"))
    assert ev.kind == "malformed" and mon.stats.malformed == 1
    (ev,) = feed(mon, can.Message(timestamp=0.3, is_error_frame=True))
    assert ev.kind == "error_frame" and mon.stats.error_frames == 1


def test_remap_by_sdo_frames_then_nmt_reset_restores_eds_mapping():
    mon = Monitor(monitor_config())

    def down(t, index, sub, value):
        return [
            msg(t, 0x601, struct.pack("<BHBL", 0x23, index, sub, value)),
            msg(t, 0x581, struct.pack("<BHBL", 0x60, index, sub, 0)),
        ]

    frames = (
        down(0.0, 0x1800, 1, 0x80000181)
        + down(0.1, 0x1A00, 0, 0)
        + down(0.2, 0x1A00, 1, 0x20010020)
        + down(0.3, 0x1A00, 0, 1)
        + down(0.4, 0x1800, 1, 0x191)
    )
    feed(mon, *frames)
    f, _ = mon.feed(msg(0.5, 0x191, struct.pack("<f", 1.25)))
    assert (
        f.kind == dec.PDO
        and f.node == 1
        and [(v["name"], v["value"]) for v in f.fields["values"]] == [("Q_W", 1.25)]
    )
    f, _ = mon.feed(msg(0.6, 0x181, struct.pack("<ff", 1.0, 2.0)))
    # the master no longer sends on 0x181: the frame is read by its consumer's view, the slave's RPDO1
    assert (f.fields["pdo"], f.fields["consumer"]) == ("RPDO1", 2)
    assert [v["name"] for v in f.fields["values"]] == ["peer_estimate_C", "peer_Q_W"]
    feed(mon, msg(0.7, 0x000, [0x82, 1]))  # reset communication: EDS values again
    f, _ = mon.feed(msg(0.8, 0x181, struct.pack("<ff", 1.0, 2.0)))
    assert [v["name"] for v in f.fields["values"]] == ["estimate_C", "Q_W"]
