"""Malformed traffic is counted and ignored; callbacks that raise never stop the device."""

from __future__ import annotations

import random
import struct

import can

from telethermo.device import DeviceSettings, NmtCommand, SyncProducer

PAIR = DeviceSettings(known_node_ids=(1, 2))  # the network: nodes 1 and 2 only


def barrier(node) -> None:
    node.sdo["mode"].raw


def test_wrong_dlc_rpdo_is_counted_ignored_and_reported_by_emcy(lab):
    dev = lab.device("master")
    node = lab.client("master")
    bus = lab.raw_bus()
    node.nmt.state = "OPERATIONAL"
    barrier(node)
    for payload in (struct.pack("<f", 40.0), struct.pack("<fh", 40.0, 1)):  # 4 and 6 bytes, 8 mapped
        bus.send(can.Message(arbitration_id=0x182, data=payload, is_extended_id=False))
    node.network.sync.transmit(1)
    barrier(node)
    assert node.sdo["malformed_frames"].raw == 2
    assert dev.read("peer_estimate_C") == 0.0
    assert node.sdo["Pre-defined error field"][1].raw == 0x8210
    bus.send(can.Message(arbitration_id=0x182, data=struct.pack("<ff", 30.0, 0.5), is_extended_id=False))
    node.network.sync.transmit(2)
    barrier(node)
    assert dev.read("peer_estimate_C") == 30.0
    assert node.sdo["Error register"].raw == 0  # the length error is over once a good PDO arrives


def test_unknown_cob_ids_and_bad_service_frames_are_counted(lab):
    dev = lab.device("master", settings=PAIR)
    node = lab.client("master")
    bus = lab.raw_bus()
    for cob, data, ext in (
        (0x7F0, b"\x01", False),
        (0x1ABCDEF, b"\x00" * 8, True),
        (0x123, b"", False),
        (0x185, b"\x00" * 8, False),
    ):  # node 5 is not on this network
        bus.send(can.Message(arbitration_id=cob, data=data, is_extended_id=ext))
    bus.send(can.Message(arbitration_id=0x000, data=b"\x01", is_extended_id=False))  # NMT, 1 byte
    bus.send(can.Message(arbitration_id=0x080, data=b"\x01\x02\x03", is_extended_id=False))  # SYNC, 3 bytes
    bus.send(can.Message(arbitration_id=0x702, data=b"\x05\x00", is_extended_id=False))  # heartbeat, 2 bytes
    bus.send(can.Message(arbitration_id=0x601, data=b"\x40\x00\x10", is_extended_id=False))  # SDO, 3 bytes
    barrier(node)
    assert node.sdo["unknown_cobid_frames"].raw == 4
    assert node.sdo["malformed_frames"].raw == 4
    assert dev.state.name == "PRE_OPERATIONAL" and dev.stats.sync_count == 0


def test_a_burst_of_garbage_leaves_the_device_working(lab):
    dev = lab.device("master", settings=PAIR)
    node = lab.client("master")
    node.tpdo.read(from_od=True)
    bus = lab.raw_bus()
    rng = random.Random(5)
    node.nmt.state = "OPERATIONAL"
    barrier(node)
    sent_bad = 0
    for _ in range(2000):
        cob = rng.choice([0x182, 0x080, 0x000, 0x702, 0x7F5, 0x3FF])
        n = rng.randrange(0, 9)
        if (
            (cob == 0x182 and n == 8)
            or (cob == 0x080 and n <= 1)
            or (cob == 0x000 and n == 2)
            or (cob == 0x702 and n == 1)
        ):
            n = {0x182: 3, 0x080: 2, 0x000: 3, 0x702: 0}[cob]  # keep every frame of the burst malformed
        bus.send(
            can.Message(
                arbitration_id=cob, data=bytes(rng.randrange(256) for _ in range(n)), is_extended_id=False
            )
        )
        sent_bad += cob in (0x182, 0x080, 0x000, 0x702)
    barrier(node)
    assert dev.stats.malformed_frames == sent_bad
    assert dev.stats.unknown_cobid_frames == 2000 - sent_bad
    dev.write("estimate_C", 31.0)
    node.network.sync.transmit(1)
    assert node.tpdo[1].wait_for_reception(2.0) is not None and node.tpdo[1]["estimate_C"].raw == 31.0
    assert node.sdo["kp_A_per_C"].raw == 0.5


def test_raising_callbacks_are_counted_and_do_not_stop_the_device(lab):
    master, slave = lab.device("master"), lab.device("slave")

    def bad(*_):
        raise RuntimeError("application bug")

    for dev in (master, slave):
        dev.add_sync_handler(bad)
        dev.add_rpdo_listener(bad)
        dev.add_nmt_listener(bad)
    node = lab.client("master")
    node.tpdo.read(from_od=True)
    master.nmt_command(NmtCommand.START, 0)
    sync = SyncProducer(master)
    for _ in range(5):
        n = master.rpdo_count(1)
        sync.transmit()
        assert master.wait_rpdo(1, after=n, timeout=3.0)  # slave still answers every SYNC
    barrier(node)
    assert master.rpdo_count(1) == 5 and slave.rpdo_count(1) == 5
    assert master.rpdo_count(2) == 5 and slave.rpdo_count(2) == 5  # the contact PDO (TPDO5 -> RPDO2) too
    # nmt + sync + (rpdo1 and rpdo2) per cycle
    assert node.sdo["callback_errors"].raw == master.stats.callback_errors == 1 + 5 + 2 * 5
    assert node.sdo["kp_A_per_C"].raw == 0.5


def test_an_invalid_first_sdo_request_gets_an_abort_not_an_exception(lab, caplog):
    """Command specifier 7 before any transfer: canopen's server would pack None into its abort frame
    and raise into the notifier; the device answers the CiA 301 abort 0x05040001 instead."""
    import logging

    dev = lab.device("master")
    bus = lab.raw_bus()
    with caplog.at_level(logging.ERROR, logger="canopen.network"):
        bus.send(
            can.Message(arbitration_id=0x601, data=bytes.fromhex("e2716fe805914f40"), is_extended_id=False)
        )
        reply = lab.recv_until(bus, lambda m: m.arbitration_id == 0x581)
    assert reply is not None and reply.data[0] == 0x80
    assert int.from_bytes(reply.data[4:8], "little") == 0x05040001
    assert not [r for r in caplog.records if r.name == "canopen.network"]
    assert dev.stats.callback_errors == 0
    node = lab.client("master")
    assert node.sdo["mode"].raw == 0  # the server still works


def test_29_bit_frames_never_reach_the_11_bit_services(lab):
    """A 29-bit frame whose identifier equals a service's (NMT 0x000, SDO 0x601, SYNC 0x080, RPDO1
    0x182, heartbeat 0x702) is only counted as unknown: canopen dispatches by the bare identifier,
    the device does not take it for NMT, SDO, SYNC, a PDO or a heartbeat."""
    dev = lab.device("master", settings=PAIR)
    node = lab.client("master")
    bus = lab.raw_bus()
    node.nmt.state = "OPERATIONAL"
    barrier(node)
    before = (dev.stats.malformed_frames, dev.stats.unknown_cobid_frames, dev.stats.sync_count)
    for cob, data in (
        (0x000, b""),
        (0x000, bytes([0x02, 1])),
        (0x601, bytes(8)),
        (0x080, b"\x01"),
        (0x182, struct.pack("<ff", 40.0, 1.0)),
        (0x702, b"\x05"),
    ):
        bus.send(can.Message(arbitration_id=cob, data=data, is_extended_id=True))
    barrier(node)
    assert dev.stats.unknown_cobid_frames - before[1] == 6
    assert dev.stats.malformed_frames == before[0] and dev.stats.sync_count == before[2]
    assert dev.state.name == "OPERATIONAL"  # the 29-bit "NMT stop" did nothing
    assert dev.stats.rpdo_count == 0 and dev.peer_status(2) == "unknown"


def test_a_segment_request_without_a_transfer_is_aborted_and_transfers_still_work(lab, caplog):
    """Upload- and download-segment requests with no segmented transfer in progress: abort 0x05040001
    (canopen's server alone raises on its empty buffer); real segmented transfers (canopen's client:
    the device name, a REAL64 model coefficient) are untouched, also right after such a request."""
    import logging

    dev = lab.device("master")
    bus = lab.raw_bus()
    # canopen's client queues every response on 0x581, ours to the raw requests too: each client is made
    # after the raw requests it must not see (a virtual bus receives only what is sent after it exists)
    with caplog.at_level(logging.ERROR):
        for command in (0x60, 0x70, 0x00, 0x0B):  # upload segment (both toggles), download segment (last)
            bus.send(can.Message(arbitration_id=0x601, data=bytes([command] + [0] * 7), is_extended_id=False))
            reply = lab.recv_until(bus, lambda m: m.arbitration_id == 0x581)
            assert reply is not None and reply.data[0] == 0x80, hex(command)
            assert int.from_bytes(reply.data[4:8], "little") == 0x05040001
        node = lab.client("master")
        assert node.sdo[0x1008].raw == "telethermo master"  # segmented upload
        node.sdo["theta"][3].raw = -1.25e-3  # segmented download (8 bytes)
        assert dev.read("theta3") == -1.25e-3
        while bus.recv(0) is not None:  # the transfers' own frames
            pass
        bus.send(can.Message(arbitration_id=0x601, data=bytes([0x60] + [0] * 7), is_extended_id=False))
        reply = lab.recv_until(bus, lambda m: m.arbitration_id == 0x581)
        assert (
            reply is not None and int.from_bytes(reply.data[4:8], "little") == 0x05040001
        )  # that upload is over
        assert lab.client("master").sdo[0x1008].raw == "telethermo master"
    assert not [r for r in caplog.records if r.name.startswith("canopen")], caplog.records
    assert dev.stats.callback_errors == 0
