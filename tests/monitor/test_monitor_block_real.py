"""The monitor's SDO decoding on real block transfers (CiA 301 §7.2.4.3.9 ff.).

The device layer serves SDO block upload and download (telethermo.device.sdo_block): the
frames recorded here are those of real transfers between canopen's SDO client (BlockUploadStream /
BlockDownloadStream) and the master Device on one python-can virtual bus, plus raw-frame clients for
what canopen's client never does (a lost segment, a bad CRC, a partial acknowledge, an abort or a
silence in the middle of a sub-block). A sniffer records every frame; the monitor is fed the record
and must report each transfer: index:sub, EDS name, value, direction, mode, or the abort and its text.
"""

from __future__ import annotations

import contextlib
import struct
import time
import uuid

import can
import canopen
import pytest
from canopen import SdoAbortedError
from canopen.sdo.client import BlockUploadStream

from telethermo.device import Device
from telethermo.device.sdo_block import crc16
from telethermo.monitor.state import Monitor

from .conftest import MASTER_EDS, monitor_config

THETA1 = (0x2310, 1)
NAME = b"telethermo master"


def pad(b: bytes) -> bytes:
    return bytes(b).ljust(8, b"\x00")


class Rig:
    """Master Device, canopen client, raw client and a recording sniffer on one virtual channel."""

    def __init__(self, stack: contextlib.ExitStack):
        self.channel = f"tt-mon-block-{uuid.uuid4().hex[:10]}"
        self.sniffer_bus = self._bus(stack)
        self.reader = can.BufferedReader()
        notifier = can.Notifier(self.sniffer_bus, [self.reader], timeout=0.05)
        stack.callback(notifier.stop)
        self.record: list[can.Message] = []
        server = self._network(stack)
        self.dev = Device(server, 1, MASTER_EDS)
        stack.callback(self.dev.close)
        self.dev.start()
        self.node = self._network(stack).add_node(1, str(MASTER_EDS))
        self.raw = self._bus(stack)

    def _bus(self, stack) -> can.BusABC:
        bus = can.Bus(interface="virtual", channel=self.channel)
        stack.callback(bus.shutdown)
        return bus

    def _network(self, stack) -> canopen.Network:
        net = canopen.Network()
        net.NOTIFIER_CYCLE = 0.05
        net.connect(interface="virtual", channel=self.channel)
        stack.callback(net.disconnect)
        return net

    # raw client: one request, wait for the device's answer (one outstanding request per channel)
    def send(self, data: bytes) -> None:
        while self.raw.recv(0) is not None:  # answers to requests made by others (canopen's client)
            pass
        self.raw.send(can.Message(arbitration_id=0x601, data=pad(data), is_extended_id=False))

    def recv(self, timeout: float = 5.0) -> bytes:
        end = time.monotonic() + timeout
        while (left := end - time.monotonic()) > 0:
            msg = self.raw.recv(left)
            if msg is not None and msg.arbitration_id == 0x581:
                return bytes(msg.data)
        raise AssertionError("no answer from the device")

    def exchange(self, data: bytes) -> bytes:
        self.send(data)
        return self.recv()

    def monitor(self) -> Monitor:
        """Feed everything recorded so far. A final expedited upload of 0x1000 marks the end: the
        sniffer receives frames in bus order, so once it has that answer it has every earlier frame."""
        assert self.exchange(bytes([0x40, 0x00, 0x10, 0x00]))[0] == 0x43
        while True:
            msg = self.reader.get_message(5.0)
            assert msg is not None, "the sniffer lost frames"
            self.record.append(msg)
            if msg.arbitration_id == 0x581 and bytes(msg.data[:4]) == bytes([0x43, 0x00, 0x10, 0x00]):
                break
        mon = Monitor(monitor_config())
        for msg in self.record:
            mon.feed(msg)
        return mon


@pytest.fixture
def rig():
    with contextlib.ExitStack() as stack:
        yield Rig(stack)


def _transfers(mon: Monitor):
    """The node's SDO records without the end marker (expedited upload of 0x1000)."""
    recs = list(mon.nodes[1].sdo_transfers)
    assert recs[-1].transfer.index == 0x1000 and recs[-1].transfer.mode == "expedited"
    return recs[:-1]


def _summary(rec):
    tr = rec.transfer
    return (tr.direction, tr.mode, tr.status, f"0x{tr.index:04X}:{tr.subindex:02X}", rec.name, rec.value)


def test_real_block_uploads_with_and_without_crc_and_in_small_sub_blocks(rig):
    rig.dev.write("theta1", -1.2345678901234567e-3)
    for crc in (True, False):
        with rig.node.sdo.open(0x1008, 0, "rb", block_transfer=True, request_crc_support=crc) as fp:
            assert fp.read() == NAME
        with rig.node.sdo.open(*THETA1, "rb", block_transfer=True, request_crc_support=crc) as fp:
            assert fp.read() == struct.pack("<d", -1.2345678901234567e-3)

    class SmallBlocks(BlockUploadStream):
        blksize = 2

    with SmallBlocks(rig.node.sdo, 0x1008, 0) as fp:  # 3 segments in sub-blocks of 2 and 1
        assert fp.read() == NAME
    mon = rig.monitor()
    name = ("upload", "block", "ok", "0x1008:00", "Manufacturer device name", "telethermo master")
    theta = ("upload", "block", "ok", "0x2310:01", "theta.theta1", -1.2345678901234567e-3)
    assert [_summary(r) for r in _transfers(mon)] == [name, theta, name, theta, name]
    assert all(r.transfer.size == len(r.transfer.data) for r in _transfers(mon))
    assert mon.log.counts["WARN"] == 0
    assert "read 0x1008:00 Manufacturer device name = telethermo master (block)" in _transfers(mon)[0].text()


def test_real_block_downloads_with_and_without_crc_and_in_small_sub_blocks(rig):
    values = (7.0e-5, -4.5e2, 1.0e6)
    for value, crc in zip(values, (True, False, True)):
        if value == values[2]:
            rig.dev.SDO_BLOCK_SIZE = 1  # two sub-blocks of one segment
        with rig.node.sdo.open(*THETA1, "wb", block_transfer=True, size=8, request_crc_support=crc) as fp:
            fp.write(struct.pack("<d", value))
        assert rig.dev.read("theta1") == value
    mon = rig.monitor()
    assert [_summary(r) for r in _transfers(mon)] == [
        ("download", "block", "ok", "0x2310:01", "theta.theta1", v) for v in values
    ]
    assert mon.log.counts["WARN"] == 0


def test_real_block_download_refusals_are_reported_with_their_abort_text(rig):
    def write(index, sub, data):
        with pytest.raises(SdoAbortedError):
            with rig.node.sdo.open(index, sub, "wb", block_transfer=True, size=len(data)) as fp:
                fp.write(data)

    write(*THETA1, struct.pack("<d", 2.0e6))  # above HighLimit: refused at the end
    write(0x1008, 0, b"another name")  # const: refused at initiate
    mon = rig.monitor()
    recs = _transfers(mon)
    assert [
        (
            r.transfer.direction,
            r.transfer.status,
            r.transfer.index,
            r.transfer.abort_code,
            r.transfer.abort_text,
            r.transfer.aborted_by,
        )
        for r in recs
    ] == [
        (
            "download",
            "aborted",
            0x2310,
            0x06090031,
            "Value of parameter written too high (download only)",
            "server",
        ),
        ("download", "aborted", 0x1008, 0x06010002, "Attempt to write a read only object", "server"),
    ]
    assert recs[0].text() == (
        "write 0x2310:01 theta.theta1 ABORT 0x06090031 "
        "Value of parameter written too high (download only) (by server)"
    )
    assert rig.dev.read("theta1") == 0.0


def test_lost_segment_retransmission_and_crc_error_on_real_frames(rig):
    data = struct.pack("<d", -8.75e5)
    initiate = bytes([0xC6]) + struct.pack("<HBL", *THETA1, 8)
    assert rig.exchange(initiate)[0] == 0xA4
    rig.send(bytes([0x01]) + data[:7])
    assert rig.exchange(bytes([0x83]) + b"garbage") == pad(bytes([0xA2, 1, 127]))  # seq 2 lost
    assert rig.exchange(bytes([0x81]) + data[7:]) == pad(bytes([0xA2, 1, 127]))
    assert rig.exchange(bytes([0xC1 | 6 << 2]) + struct.pack("<H", crc16(data))) == pad(b"\xa1")
    assert rig.exchange(initiate)[0] == 0xA4
    rig.send(bytes([0x01]) + data[:7])
    rig.exchange(bytes([0x82]) + data[7:])
    assert rig.exchange(bytes([0xC1 | 6 << 2]) + struct.pack("<H", crc16(data) ^ 1))[0] == 0x80
    mon = rig.monitor()
    ok, bad = _transfers(mon)
    assert _summary(ok) == ("download", "block", "ok", "0x2310:01", "theta.theta1", -8.75e5)
    assert (
        bad.transfer.status,
        bad.transfer.abort_code,
        bad.transfer.abort_text,
        bad.transfer.aborted_by,
    ) == ("aborted", 0x05040004, "CRC error (block mode only)", "server")


def test_partial_acknowledge_of_a_real_block_upload(rig):
    assert rig.exchange(bytes([0xA4]) + struct.pack("<HBBB", 0x1008, 0, 127, 0))[0] == 0xC6
    rig.send(bytes([0xA3]))
    assert [rig.recv()[0] for _ in range(3)] == [0x01, 0x02, 0x83]
    rig.send(bytes([0xA2, 1, 127]))  # only segment 1 kept: 2 and 3 again
    assert [rig.recv()[0] for _ in range(2)] == [0x01, 0x82]
    assert rig.exchange(bytes([0xA2, 2, 127]))[0] == 0xC1 | 4 << 2
    rig.send(bytes([0xA1]))
    mon = rig.monitor()
    (rec,) = _transfers(mon)
    assert _summary(rec) == (
        "upload",
        "block",
        "ok",
        "0x1008:00",
        "Manufacturer device name",
        "telethermo master",
    )
    assert mon.log.counts["WARN"] == 0


def test_aborts_in_the_middle_of_a_sub_block_are_reported(rig):
    """A client abort between two segments of a block download, and the server's timeout abort while
    it waits for the acknowledge of a block upload's sub-block: both frames start with 0x80 where a
    segment (c | seqno) is due, and are aborts (seqno 0 does not exist)."""
    rig.dev.SDO_BLOCK_TIMEOUT_S = 0.05
    assert rig.exchange(bytes([0xC6]) + struct.pack("<HBL", *THETA1, 8))[0] == 0xA4
    rig.send(bytes([0x01]) + b"\x00" * 7)
    rig.send(struct.pack("<BHBL", 0x80, *THETA1, 0x05040000))  # the client gives up
    assert rig.exchange(bytes([0xA4]) + struct.pack("<HBBB", 0x1008, 0, 127, 0))[0] == 0xC6
    rig.send(bytes([0xA3]))
    assert [rig.recv()[0] for _ in range(3)] == [0x01, 0x02, 0x83]
    timeout = rig.recv()  # no acknowledge comes
    assert timeout[0] == 0x80 and struct.unpack_from("<L", timeout, 4)[0] == 0x05040000
    mon = rig.monitor()
    client_abort, server_abort = _transfers(mon)
    assert (
        client_abort.transfer.direction,
        client_abort.transfer.status,
        client_abort.transfer.abort_code,
        client_abort.transfer.aborted_by,
    ) == ("download", "aborted", 0x05040000, "client")
    assert (
        server_abort.transfer.direction,
        server_abort.transfer.status,
        server_abort.transfer.abort_code,
        server_abort.transfer.abort_text,
        server_abort.transfer.aborted_by,
    ) == ("upload", "aborted", 0x05040000, "SDO protocol timed out", "server")
    assert server_abort.text() == (
        "read 0x1008:00 Manufacturer device name ABORT 0x05040000 SDO protocol timed out (by server)"
    )
