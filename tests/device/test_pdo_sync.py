"""PDOs and SYNC: TPDOs on SYNC with the OD's values (counted transmission types), RPDOs into the OD
at the next SYNC, the SYNC counter and the producer's own tick, and PDO configuration by canopen's
own PDO client (dynamic mapping)."""

from __future__ import annotations

import struct
import threading
import time

import can
import pytest
from canopen import SdoAbortedError

from telethermo.device import DeviceSettings, NmtCommand, NmtState, OdWriteError, SyncProducer
from telethermo.nodes.launch import wait_for


def drain(bus) -> list[can.Message]:
    out = []
    while (m := bus.recv(0)) is not None:
        out.append(m)
    return out


def barrier(node) -> None:
    """An SDO round trip: the device handles frames in order, so everything sent before was handled
    and everything it sent in reply to those frames is already on the bus."""
    node.sdo["mode"].raw


def test_tpdo1_on_every_sync_carries_the_od_values(lab):
    dev = lab.device("master")
    node = lab.client("master")
    node.tpdo.read(from_od=True)
    dev.nmt_command(NmtCommand.START, 1)
    dev.write("estimate_C", 33.25)
    dev.write("Q_W", -0.125)
    node.network.sync.transmit(1)
    assert node.tpdo[1].wait_for_reception(2.0) is not None
    assert node.tpdo[1]["estimate_C"].raw == 33.25 and node.tpdo[1]["Q_W"].raw == -0.125
    dev.write("estimate_C", 20.5)
    node.network.sync.transmit(2)
    assert node.tpdo[1].wait_for_reception(2.0) is not None
    assert node.tpdo[1]["estimate_C"].raw == 20.5


def test_transmission_types_are_counted(lab):
    """TPDO1 (type 1) on every SYNC, status TPDOs 2..4 (type 10) on every 10th."""
    lab.device("slave")
    node = lab.client("slave")
    bus = lab.raw_bus()
    node.nmt.state = "OPERATIONAL"
    barrier(node)
    drain(bus)
    for k in range(1, 36):
        node.network.sync.transmit(k)
    barrier(node)
    frames = drain(bus)
    count = {cob: sum(1 for m in frames if m.arbitration_id == cob) for cob in (0x182, 0x282, 0x382, 0x482)}
    assert count == {0x182: 35, 0x282: 3, 0x382: 3, 0x482: 3}


def test_sync_start_value_delays_the_first_transmission(lab):
    lab.device("slave")
    node = lab.client("slave")
    comm = node.sdo["TPDO2 communication parameter"]
    cob = comm["COB-ID used by TPDO"].raw
    comm["COB-ID used by TPDO"].raw = cob | 0x80000000  # only while the PDO is invalid (CiA 301, CANopenNode)
    comm["SYNC start value"].raw = 7
    comm["COB-ID used by TPDO"].raw = cob
    bus = lab.raw_bus()
    node.nmt.state = "OPERATIONAL"
    barrier(node)
    drain(bus)
    seen = []
    for k in range(1, 31):
        node.network.sync.transmit(k)
        barrier(node)
        if any(m.arbitration_id == 0x282 for m in drain(bus)):
            seen.append(k)
    assert seen == [7, 17, 27]


def test_sync_start_value_and_mapping_change_only_while_the_pdo_is_invalid(lab):
    """CiA 301 7.5.2.35/36: SYNC start value and mapping of a valid PDO are refused (0x06090030, 0x06010000,
    as
    CANopenNode); the mapping procedure (invalid, sub 0 = 0, entries, sub 0 = n, valid) is accepted."""
    lab.device("slave")
    node = lab.client("slave")
    comm, mapping = node.sdo[0x1801], node.sdo[0x1A01]
    before = (comm[6].raw, mapping[0].raw, mapping[1].raw)
    for fn, code in (
        (lambda: setattr(comm[6], "raw", 3), 0x06090030),
        (lambda: setattr(mapping[0], "raw", 0), 0x06010000),
        (lambda: setattr(mapping[1], "raw", 0x20000020), 0x06010000),
    ):
        with pytest.raises(SdoAbortedError) as exc:
            fn()
        assert exc.value.code == code
    assert (comm[6].raw, mapping[0].raw, mapping[1].raw) == before
    cob = comm[1].raw
    comm[1].raw = cob | 0x80000000
    with pytest.raises(SdoAbortedError) as exc:  # entries only while sub 0 is 0
        mapping[1].raw = 0x20000020
    assert exc.value.code == 0x06010000
    mapping[0].raw = 0
    mapping[1].raw = 0x20000020
    mapping[0].raw = 1
    comm[6].raw = 3
    comm[1].raw = cob
    assert (comm[6].raw, mapping[0].raw, mapping[1].raw, comm[1].raw) == (3, 1, 0x20000020, cob)


def test_a_sync_of_the_wrong_length_is_not_processed_and_raises_emcy_0x8240(lab):
    """CiA 301 7.2.5: with 0x1019 > 0 a SYNC carries the counter (DLC 1); DLC 0 or 2 is refused (no TPDO) with
    EMCY 0x8240 "unexpected SYNC data length" (byte 3: the length), its error reset at once (0x1003 keeps
    it)."""
    lab.device("slave")
    node = lab.client("slave")
    bus = lab.raw_bus()
    node.nmt.state = "OPERATIONAL"
    barrier(node)
    drain(bus)
    for data in (b"", b"\x01\x02"):
        bus.send(can.Message(arbitration_id=0x80, data=data, is_extended_id=False))
    barrier(node)
    frames = drain(bus)
    emcy = [bytes(m.data) for m in frames if m.arbitration_id == 0x82]
    deadline = time.monotonic() + 5.0  # EMCYs are spaced by the inhibit time 0x1015
    while sum(d[:2] == b"\x40\x82" for d in emcy) < 2 and time.monotonic() < deadline:
        m = bus.recv(0.1)
        if m is not None:
            frames.append(m)
            emcy += [bytes(m.data)] if m.arbitration_id == 0x82 else []
    assert not any(m.arbitration_id == 0x182 for m in frames), "a wrong-length SYNC was processed"
    assert [(int.from_bytes(d[:2], "little"), d[3]) for d in emcy if d[:2] != b"\0\0"] == [
        (0x8240, 0),
        (0x8240, 2),
    ]
    assert node.sdo[0x1001].raw == 0 and node.sdo[0x1003][1].raw & 0xFFFF == 0x8240
    node.network.sync.transmit(1)  # the right length: processed
    assert lab.recv_until(bus, lambda m: m.arbitration_id == 0x182) is not None


def test_sync_counter_wraps_at_0x1019_and_the_producer_ticks_itself(lab):
    # CiA 301: 0x1019 may change only while 0x1006 is 0 (a device configured without a cycle period)
    dev = lab.device("master", settings=DeviceSettings(sync_period_us=0))
    node = lab.client("master")
    node.sdo["Synchronous counter overflow value"].raw = 5
    ticks = []
    dev.add_sync_handler(lambda t: ticks.append(t.counter))
    bus = lab.raw_bus()
    sync = SyncProducer(dev)
    dev.nmt_command(NmtCommand.START, 0)
    for _ in range(12):
        sync.transmit()
    frames = [m for m in drain(bus) if m.arbitration_id in (0x80, 0x181)]
    counters = [m.data[0] for m in frames if m.arbitration_id == 0x80]
    assert counters == [1, 2, 3, 4, 5, 1, 2, 3, 4, 5, 1, 2]
    assert ticks == counters  # the producer's own device saw every SYNC it sent
    assert [m.arbitration_id for m in frames] == [0x80, 0x181] * 12  # own TPDO1 after each SYNC
    node.sdo["Synchronous counter overflow value"].raw = 0
    sync.transmit()
    assert [m.dlc for m in drain(bus) if m.arbitration_id == 0x80] == [0]
    node.sdo["Synchronous counter overflow value"].raw = 5
    sync.transmit()
    sync.transmit()
    dev.nmt_command(NmtCommand.RESET_COMMUNICATION, 1)  # 0x1019 back to 240, counter restarts at 1
    sync.transmit()
    assert [m.data[0] for m in drain(bus) if m.arbitration_id == 0x80] == [3, 4, 1]


def test_only_the_configured_producer_may_send_sync(lab):
    slave = lab.device("slave")
    with pytest.raises(RuntimeError, match="not the SYNC producer"):
        SyncProducer(slave).transmit()


def test_rpdo_reaches_the_od_at_the_next_sync(lab):
    dev = lab.device("master")
    events = []
    dev.add_rpdo_listener(events.append)
    node = lab.client("master")
    peer = node.network.add_node(2, str(__import__("bus_config").path("slave.eds")))
    peer.tpdo.read(from_od=True)  # canopen's PDO class produces the slave's TPDO1 frame for us
    node.nmt.state = "OPERATIONAL"
    node.network.sync.transmit(1)
    barrier(node)
    peer.tpdo[1]["estimate_C"].raw = 34.5
    peer.tpdo[1]["Q_W"].raw = 0.75
    peer.tpdo[1].transmit()
    barrier(node)
    assert node.sdo["peer_estimate_C"].raw == 0.0  # synchronous RPDO: not before the next SYNC
    assert [(e.number, e.values, e.sync_counter) for e in events] == [
        (1, {"peer_estimate_C": 34.5, "peer_Q_W": 0.75}, 1)
    ]
    node.network.sync.transmit(2)
    barrier(node)
    assert node.sdo["peer_estimate_C"].raw == 34.5 and node.sdo["peer_Q_W"].raw == 0.75
    assert dev.read("rpdo_count") == 1


def test_rpdo_ignored_outside_operational(lab):
    dev = lab.device("master")
    bus = lab.raw_bus()
    node = lab.client("master")
    bus.send(can.Message(arbitration_id=0x182, data=struct.pack("<ff", 40.0, 1.0), is_extended_id=False))
    node.network.sync.transmit(1)
    barrier(node)
    assert dev.read("peer_estimate_C") == 0.0 and dev.stats.rpdo_ignored == 1


def test_two_devices_exchange_in_lockstep(lab):
    """Both sides write peer+1 on each SYNC: after n cycles both hold n (each sees the other's
    value of the previous cycle, committed at the SYNC)."""
    master, slave = lab.device("master"), lab.device("slave")
    for dev in (master, slave):
        w, r = dev.writer("estimate_C"), dev.reader("peer_estimate_C")
        dev.add_sync_handler(lambda tick, w=w, r=r: w(r() + 1.0))
    fresh = []
    slave.add_sync_handler(lambda tick: fresh.append(tick.fresh_rpdos))
    master.nmt_command(NmtCommand.START, 0)
    sync = SyncProducer(master)
    for _ in range(200):
        n, n2 = master.rpdo_count(1), master.rpdo_count(2)
        sync.transmit()
        # every PDO of the cycle (TPDO1, then the contact TPDO5) is in before the next SYNC
        assert master.wait_rpdo(1, after=n, timeout=5.0) and master.wait_rpdo(2, after=n2, timeout=5.0)
    assert master.read("estimate_C") == 200.0 and slave.read("estimate_C") == 200.0
    assert fresh[0] == () and all(f == (1, 2) for f in fresh[1:])  # RPDO1 and the contact RPDO2


def test_pdo_reconfiguration_with_canopens_pdo_client(lab):
    """canopen's RemoteNode PDO save(): disable, set type/timer, remap, enable."""
    dev = lab.device("master")
    node = lab.client("master")
    node.tpdo.read()  # over SDO
    tp3 = node.tpdo[3]
    tp3.clear()
    tp3.add_variable("T_sink_C")
    tp3.add_variable("cycle_counter")
    tp3.trans_type = 1
    tp3.save()
    dev.write("T_sink_C", 41.5)
    dev.write("cycle_counter", 77)
    node.nmt.state = "OPERATIONAL"
    barrier(node)
    node.network.sync.transmit(1)
    assert tp3.wait_for_reception(2.0) is not None
    assert tp3["T_sink_C"].raw == 41.5 and tp3["cycle_counter"].raw == 77


def test_event_driven_tpdo_with_event_timer(lab):
    dev = lab.device("master")
    node = lab.client("master")
    node.tpdo.read()
    tp2 = node.tpdo[2]
    tp2.trans_type = 255
    tp2.event_timer = 20
    tp2.save()
    got = threading.Event()
    stamps = []

    def on_pdo(m):
        stamps.append(m.timestamp)
        if len(stamps) >= 4:
            got.set()

    tp2.add_callback(on_pdo)
    dev.nmt_command(NmtCommand.START, 0)
    assert got.wait(3.0)  # sent by the event timer, no SYNC at all
    dev.write("T_sensor_C", 36.0)
    dev.trigger_tpdo(2)
    # the event timer keeps sending too: a TPDO2 it sent just before the write (the old value) may reach the
    # client's notifier after the wait began, so wait for the frame that carries the new value
    assert wait_for(lambda: tp2["T_sensor_C"].raw == 36.0, 2.0, poll_s=0.005)


def test_mapping_rules(lab):
    lab.device("master")
    node = lab.client("master")
    mapping = node.sdo["TPDO3 mapping parameter"]
    node.sdo["TPDO3 communication parameter"]["COB-ID used by TPDO"].raw = 0x80000000 | 0x381
    mapping[0].raw = 0
    with pytest.raises(SdoAbortedError) as exc:
        mapping[1].raw = (0x2200 << 16) | 32  # kp_A_per_C is not PDO-mappable
    assert exc.value.code == 0x06040041
    with pytest.raises(SdoAbortedError) as exc:
        mapping[1].raw = (0x2000 << 16) | 16  # a REAL32 mapped with 16 bits
    assert exc.value.code == 0x06040041
    for i, idx in enumerate((0x2000, 0x2001, 0x2002), 1):
        mapping[i].raw = (idx << 16) | 32
    with pytest.raises(SdoAbortedError) as exc:
        mapping[0].raw = 3  # 96 bits > 64
    assert exc.value.code == 0x06040042
    mapping[0].raw = 2
    assert mapping[0].raw == 2
    with pytest.raises(SdoAbortedError) as exc:  # a valid PDO's COB-ID cannot change
        node.sdo["TPDO1 communication parameter"]["COB-ID used by TPDO"].raw = 0x1F1
    assert exc.value.code == 0x06090030
    with pytest.raises(SdoAbortedError) as exc:
        node.sdo["TPDO1 communication parameter"]["Transmission type"].raw = 250  # reserved
    assert exc.value.code == 0x06090030


def test_nan_and_inf_in_an_rpdo_reach_the_od_unchanged(lab):
    """The device does not judge PDO data: NaN/inf go to the OD for the safety envelope to see."""
    import math

    dev = lab.device("master")
    node = lab.client("master")
    bus = lab.raw_bus()
    node.nmt.state = "OPERATIONAL"
    barrier(node)
    bus.send(
        can.Message(arbitration_id=0x182, data=struct.pack("<ff", math.nan, math.inf), is_extended_id=False)
    )
    node.network.sync.transmit(1)
    barrier(node)
    assert math.isnan(dev.read("peer_estimate_C")) and dev.read("peer_Q_W") == math.inf
    assert dev.stats.malformed_frames == 0 and dev.stats.rpdo_count == 1


def test_a_peer_answering_before_the_producers_own_tick_is_not_committed_one_cycle_early(lab):
    """The race SyncProducer.transmit closes: the peer's TPDO k arrives while the producer's thread
    is still between sending SYNC k and processing its own SYNC k (made certain here: the producer's
    network, once it has sent a SYNC, waits until the peer's answer is on the bus and the producer's
    receive thread has had time to handle it). The PDO must be committed at SYNC k+1, never at SYNC k:
    at every SYNC the producer sees the peer's value of the previous SYNC."""
    master, slave = lab.device("master"), lab.device("slave")
    w = slave.writer("estimate_C")
    slave.add_sync_handler(lambda tick: w(float(tick.counter)))  # the peer answers SYNC k with k
    seen = []
    r = master.reader("peer_estimate_C")
    master.add_sync_handler(lambda tick: seen.append((tick.counter, tick.fresh_rpdos, r())))
    observer = lab.raw_bus()
    net = master.network
    send = net.send_message

    def slow_send(cob_id, data, remote=False):
        send(cob_id, data, remote)
        if cob_id == 0x80:  # a thread switch right after the SYNC: the peer's TPDO k gets here first
            lab.recv_until(
                observer, lambda m: m.arbitration_id == 0x182 and m.data[:4] == struct.pack("<f", data[0])
            )
            lab.recv_until(
                observer, lambda m: m.arbitration_id == 0x682
            )  # and its contact PDO, sent after it
            threading.Event().wait(0.02)

    master.nmt_command(NmtCommand.START, 0)
    sync = SyncProducer(master)
    drain(observer)
    net.send_message = slow_send
    try:
        for _ in range(20):
            n, n2 = master.rpdo_count(1), master.rpdo_count(2)
            sync.transmit()
            # every PDO of the cycle is in before the next SYNC, as the lockstep producer waits for the last
            # one
            assert master.wait_rpdo(1, after=n, timeout=5.0) and master.wait_rpdo(2, after=n2, timeout=5.0)
            drain(observer)
    finally:
        net.send_message = send
    assert [c for c, _, _ in seen] == list(range(1, 21))
    assert seen[0][1] == () and all(f == (1, 2) for _, f, _ in seen[1:])
    assert [v for _, _, v in seen[1:]] == [float(k - 1) for k in range(2, 21)]


def test_a_stopped_producer_sends_no_sync_and_resumes_on_nmt_start(lab):
    """CiA 301: in STOPPED only NMT and heartbeat; the SYNC producer simply does not produce (issue 12
    FAIL 1: it raised into the node's SYNC loop and killed the real-time master)."""
    dev = lab.device("master")
    node = lab.client("master")
    bus = lab.raw_bus()
    sync = SyncProducer(dev)
    dev.nmt_command(NmtCommand.START, 0)
    for _ in range(3):
        sync.transmit()
    node.nmt.send_command(0x02)  # NMT stop from another master (canopen's NmtMaster)
    assert wait_for(lambda: dev.state is NmtState.STOPPED, 10.0, poll_s=0.005)
    assert sync.transmit() is None and sync.transmit() is None
    node.nmt.send_command(0x01)  # NMT start: SYNC again, the counter restarts at 1
    assert wait_for(lambda: dev.state is NmtState.OPERATIONAL, 10.0, poll_s=0.005)
    assert sync.transmit() is not None and sync.transmit() is not None
    syncs = [m.data[0] for m in drain(bus) if m.arbitration_id == 0x80]
    assert syncs == [1, 2, 3, 1, 2]  # before the stop, then CANopenNode's restart at 1


def test_0x1019_is_refused_while_the_communication_cycle_period_runs(lab):
    """CiA 301 (object 0x1019): changed only while 0x1006 is 0, else 0x08000022, as CANopenNode's
    OD_write_1019 (issue 12 deviation: it was accepted with 0x1006 = 10 ms)."""
    dev = lab.device("master")
    node = lab.client("master")
    assert node.sdo["Communication cycle period"].raw == 10000
    with pytest.raises(SdoAbortedError) as exc:
        node.sdo["Synchronous counter overflow value"].raw = 5
    assert exc.value.code == 0x08000022
    assert node.sdo["Synchronous counter overflow value"].raw == 240 and dev.read(0x1019) == 240
    with pytest.raises(SdoAbortedError) as exc:
        node.sdo["Synchronous counter overflow value"].raw = 1  # an invalid value stays 0x06090030
    assert exc.value.code == 0x06090030
    other = lab.device("slave", settings=DeviceSettings(sync_period_us=0))  # configured without a period
    lab.client("slave").sdo["Synchronous counter overflow value"].raw = 5
    assert other.read(0x1019) == 5


def test_0x1006_reports_the_configured_period_and_refuses_another(lab):
    """Issue 25: the SYNC schedule is the node program's (lockstep: SYNC k+1 when the PDOs of k are in;
    real time: the control period, which the controller and the models also use), so a write of another
    period is refused with 0x08000021 (local control) and 0x1006 keeps the configured value; the same
    value is accepted. Was: accepted and ignored."""
    dev = lab.device("master", settings=DeviceSettings(sync_period_us=5000))
    node = lab.client("master")
    assert node.sdo["Communication cycle period"].raw == 5000
    for value in (0, 1000, 10000):
        with pytest.raises(SdoAbortedError) as exc:
            node.sdo["Communication cycle period"].raw = value
        assert exc.value.code == 0x08000021
        assert node.sdo["Communication cycle period"].raw == 5000 and dev.read(0x1006) == 5000
    node.sdo["Communication cycle period"].raw = 5000
    with pytest.raises(OdWriteError):  # the program's own write too: configure it instead
        dev.write(0x1006, 1000)
