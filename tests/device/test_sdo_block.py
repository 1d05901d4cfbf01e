"""SDO block upload and block download (CiA 301 §7.2.4.3.9 ff.) served by the device.

Real transfers: canopen's own SDO client (``SdoClient.open(..., block_transfer=True)``, its
BlockUploadStream/BlockDownloadStream) against the Device on python-can's virtual bus, with and
without CRC, in one and in several sub-blocks; refusals through the device's normal write path
(EDS range, write validators, read-only). The cases canopen's client cannot produce (a corrupted CRC,
a lost segment, an invalid sequence number or block size, a client that goes silent or aborts, a
protocol switch threshold) are raw frames. The last tests drive the pure state machine alone with
payloads of several 127-segment blocks (the OD has no object that large).
"""

from __future__ import annotations

import math
import struct

import can
import pytest
from canopen import SdoAbortedError
from canopen.sdo.base import CrcXmodem
from canopen.sdo.client import BlockUploadStream

from telethermo.device.sdo_block import BlockServer, crc16

REQ, RESP = 0x601, 0x581
THETA1 = (0x2310, 1)  # REAL64 model coefficient, range [-1e6, 1e6]


def abort_code(fn) -> int:
    with pytest.raises(SdoAbortedError) as exc:
        fn()
    return exc.value.code


def block_read(node, index: int, sub: int = 0, crc: bool = True) -> bytes:
    with node.sdo.open(index, sub, "rb", block_transfer=True, request_crc_support=crc) as fp:
        return fp.read()


def block_write(node, index: int, sub: int, data: bytes, crc: bool = True) -> None:
    with node.sdo.open(index, sub, "wb", block_transfer=True, size=len(data), request_crc_support=crc) as fp:
        fp.write(data)


def pad(b: bytes) -> bytes:
    return bytes(b).ljust(8, b"\x00")


class Raw:
    """A client made of raw frames on 0x601, reading the device's answers on 0x581."""

    def __init__(self, lab):
        self.lab, self.bus = lab, lab.raw_bus()

    def send(self, data: bytes) -> None:
        self.bus.send(can.Message(arbitration_id=REQ, data=pad(data), is_extended_id=False))

    def recv(self, timeout: float = 2.0) -> bytes | None:
        msg = self.lab.recv_until(self.bus, lambda m: m.arbitration_id == RESP, timeout)
        return None if msg is None else bytes(msg.data)

    def exchange(self, data: bytes) -> bytes | None:
        self.send(data)
        return self.recv()

    def silent(self) -> bool:
        """No answer: proven by an expedited upload whose answer is the next frame on 0x581."""
        reply = self.exchange(bytes([0x40, 0x00, 0x10, 0x00]))  # 0x1000 device type
        return reply is not None and reply[0] == 0x43


def abort_of(frame: bytes | None) -> int | None:
    assert frame is not None, "no answer"
    return struct.unpack_from("<L", frame, 4)[0] if frame[0] == 0x80 else None


def bits(x: float) -> bytes:
    return struct.pack("<d", x)


# ---------------------------------------------------------------------------- canopen's client
@pytest.mark.parametrize("crc", [True, False])
def test_block_upload_of_a_real64_and_the_device_name(lab, crc):
    dev = lab.device("master")
    node = lab.client("master")
    dev.write("theta1", -1.2345678901234567e-3)
    assert block_read(node, *THETA1, crc=crc) == bits(-1.2345678901234567e-3)  # bit for bit
    assert block_read(node, 0x1008, 0, crc=crc) == b"telethermo master"  # 17 bytes: 7 + 7 + 3
    assert dev.stats.callback_errors == 0


def test_block_upload_goes_through_the_read_callbacks(lab):
    """A diagnostics object served live by the device's read callback (0x2710 malformed_frames)."""
    dev = lab.device("master")
    raw = Raw(lab)
    raw.bus.send(can.Message(arbitration_id=REQ, data=b"\x40", is_extended_id=False))  # 1-byte SDO: malformed
    node = lab.client("master")
    node.sdo["mode"].raw  # barrier: the malformed frame was handled
    assert struct.unpack("<L", block_read(node, 0x2710, 0))[0] == dev.stats.malformed_frames == 1


@pytest.mark.parametrize("crc", [True, False])
def test_block_download_of_a_real64_stores_it_through_the_write_path(lab, crc):
    dev = lab.device("master")
    node = lab.client("master")
    seen = []
    dev.add_write_listener(lambda ev: seen.append((ev.index, ev.subindex, ev.value)))
    value = 7.0e-5 * math.pi
    block_write(node, *THETA1, bits(value), crc=crc)
    assert dev.read("theta1") == value
    assert node.sdo.upload(*THETA1) == bits(value)  # read back (segmented) bit for bit
    assert seen == [(0x2310, 1, value)]  # the write listener ran, once


def test_several_sub_blocks_in_both_directions(lab):
    """The OD has no object above 127 x 7 bytes: small block sizes make several sub-blocks. Download:
    the server asks for 1 segment per sub-block (REAL64 = 2 sub-blocks, 2 acknowledges). Upload: the
    client asks for 2 (device name = 3 segments = 2 sub-blocks)."""
    dev = lab.device("master")
    node = lab.client("master")
    raw = Raw(lab)  # sniffs the device's answers
    dev.SDO_BLOCK_SIZE = 1
    block_write(node, *THETA1, bits(-4.5e2))
    assert dev.read("theta1") == -4.5e2
    acks = [f for f in iter(lambda: raw.recv(0.2), None) if f[0] == 0xA2]
    assert [(f[1], f[2]) for f in acks] == [(1, 1), (1, 1)]

    class SmallBlocks(BlockUploadStream):
        blksize = 2

    with SmallBlocks(node.sdo, 0x1008, 0, request_crc_support=True) as fp:
        assert fp.read() == b"telethermo master"
    segments = [f[0] for f in iter(lambda: raw.recv(0.2), None) if f[0] & 0x7F in (1, 2)]
    assert segments == [0x01, 0x02, 0x81]  # seq 1, 2 | seq 1 with c
    dev.SDO_BLOCK_SIZE = 127
    assert block_read(node, *THETA1) == bits(-4.5e2)


@pytest.mark.parametrize(
    "value, code",
    [
        (2.0e6, 0x06090031),  # above HighLimit 1e6
        (-2.0e6, 0x06090032),  # below LowLimit
        (math.nan, 0x06090030),  # NaN
    ],
)
def test_block_download_out_of_range_is_refused_and_the_value_unchanged(lab, value, code):
    dev = lab.device("master")
    node = lab.client("master")
    dev.write("theta1", 0.25)
    seen = []
    dev.add_write_listener(seen.append)
    assert abort_code(lambda: block_write(node, *THETA1, bits(value))) == code
    assert dev.read("theta1") == 0.25 and node.sdo.upload(*THETA1) == bits(0.25)
    assert seen == []


def test_block_download_refused_by_a_write_validator(lab):
    dev = lab.device("master")
    node = lab.client("master")
    dev.add_write_validator("theta1", lambda v: 0x08000022 if v > 1.0 else None)
    assert abort_code(lambda: block_write(node, *THETA1, bits(2.0))) == 0x08000022
    assert dev.read("theta1") == 0.0
    block_write(node, *THETA1, bits(0.5))
    assert dev.read("theta1") == 0.5


def test_block_download_to_read_only_or_missing_objects_is_refused_at_initiate(lab):
    dev = lab.device("master")
    node = lab.client("master")
    ro = (dev.info.get("T_sensor_C").index, dev.info.get("T_sensor_C").subindex)
    assert abort_code(lambda: block_write(node, 0x1008, 0, b"another name")) == 0x06010002  # const
    assert abort_code(lambda: block_write(node, *ro, struct.pack("<f", 1.0))) == 0x06010002
    assert abort_code(lambda: block_write(node, 0x2FFF, 0, b"12345678")) == 0x06020000
    assert abort_code(lambda: block_write(node, 0x2310, 0x7F, b"12345678")) == 0x06090011
    assert block_read(node, 0x1008, 0) == b"telethermo master"


def test_block_download_of_a_wrong_length_is_refused_at_initiate(lab):
    """An indicated size other than the object's is refused at the initiate, as CANopenNode does:
    shorter 0x06070013, longer 0x06070012 (the client sends no data)."""
    dev = lab.device("master")
    node = lab.client("master")
    assert abort_code(lambda: block_write(node, *THETA1, b"\x00" * 4)) == 0x06070013  # 4 bytes to a REAL64
    assert abort_code(lambda: block_write(node, *THETA1, b"\x00" * 12)) == 0x06070012
    assert dev.read("theta1") == 0.0


def test_segmented_and_expedited_transfers_still_work_between_block_transfers(lab):
    dev = lab.device("master")
    node = lab.client("master")
    block_write(node, *THETA1, bits(3.0))
    assert node.sdo[0x1008].raw == "telethermo master"  # segmented upload
    node.sdo["theta"][2].raw = -2.0  # segmented download
    assert block_read(node, 0x2310, 2) == bits(-2.0)
    node.sdo["mode"].raw = 1  # expedited
    assert dev.read("mode") == 1 and dev.read("theta1") == 3.0


# ---------------------------------------------------------------------------- raw frames
def _initiate_download(raw: Raw, size: int, *, crc: bool = True) -> bytes:
    cmd = 0xC2 | (0x04 if crc else 0)
    return raw.exchange(bytes([cmd]) + struct.pack("<HBL", *THETA1, size))


def test_a_corrupted_crc_is_refused_with_0x05040004(lab):
    dev = lab.device("master")
    raw = Raw(lab)
    data = bits(12.5)
    assert _initiate_download(raw, 8) == pad(bytes([0xA4]) + struct.pack("<HBB", *THETA1, 127))
    raw.send(bytes([0x01]) + data[:7])
    assert raw.exchange(bytes([0x82]) + data[7:]) == pad(bytes([0xA2, 2, 127]))
    bad = crc16(data) ^ 0x0100
    reply = raw.exchange(bytes([0xC1 | 6 << 2]) + struct.pack("<H", bad))
    assert abort_of(reply) == 0x05040004 and reply[1:4] == bytes([0x10, 0x23, 0x01])
    assert dev.read("theta1") == 0.0
    # the same transfer with the right CRC is stored
    _initiate_download(raw, 8)
    raw.send(bytes([0x01]) + data[:7])
    raw.exchange(bytes([0x82]) + data[7:])
    assert raw.exchange(bytes([0xC1 | 6 << 2]) + struct.pack("<H", crc16(data))) == pad(b"\xa1")
    assert dev.read("theta1") == 12.5


def test_a_lost_segment_is_acknowledged_with_the_last_good_seqno_and_resent(lab):
    """Segment 2 lost: segment 3 (with c) is out of sequence, ignored, and the acknowledge carries
    ackseq 1; the client resends from the segment after it, renumbered from 1 (CiA 301)."""
    dev = lab.device("master")
    raw = Raw(lab)
    data = bits(-8.75e5)
    _initiate_download(raw, 8)
    raw.send(bytes([0x01]) + data[:7])
    assert raw.exchange(bytes([0x83]) + b"garbage") == pad(bytes([0xA2, 1, 127]))  # seq 2 never came
    assert raw.exchange(bytes([0x81]) + data[7:]) == pad(bytes([0xA2, 1, 127]))  # resent as seq 1, last
    assert raw.exchange(bytes([0xC1 | 6 << 2]) + struct.pack("<H", crc16(data))) == pad(b"\xa1")
    assert dev.read("theta1") == -8.75e5


def test_segment_one_lost_gives_ackseq_0(lab):
    dev = lab.device("master")
    raw = Raw(lab)
    data = bits(1.5)
    _initiate_download(raw, 8, crc=False)
    assert raw.exchange(bytes([0x82]) + data[7:]) == pad(bytes([0xA2, 0, 127]))  # nothing in sequence
    raw.send(bytes([0x01]) + data[:7])
    assert raw.exchange(bytes([0x82]) + data[7:]) == pad(bytes([0xA2, 2, 127]))
    assert raw.exchange(bytes([0xC1 | 6 << 2, 0xDE, 0xAD])) == pad(b"\xa1")  # no CRC agreed: not checked
    assert dev.read("theta1") == 1.5


def test_invalid_sequence_number_block_size_and_command_are_aborted(lab):
    dev = lab.device("master")
    raw = Raw(lab)
    dev.SDO_BLOCK_SIZE = 4
    _initiate_download(raw, 8)
    assert abort_of(raw.exchange(bytes([0x05]) + b"1234567")) == 0x05040003  # seqno 5 > blksize 4
    _initiate_download(raw, 8)
    assert abort_of(raw.exchange(bytes([0x00]) + b"1234567")) == 0x05040003  # seqno 0
    upload = bytes([0xA4]) + struct.pack("<HBBB", 0x1008, 0, 0, 0)
    assert abort_of(raw.exchange(upload)) == 0x05040002  # blksize 0
    upload = bytes([0xA4]) + struct.pack("<HBBB", 0x1008, 0, 128, 0)
    assert abort_of(raw.exchange(upload)) == 0x05040002  # blksize 128
    assert raw.exchange(bytes([0xA4]) + struct.pack("<HBBB", 0x1008, 0, 127, 0))[0] == 0xC6
    assert abort_of(raw.exchange(bytes([0xA2, 0, 127]))) == 0x05040001  # acknowledge before start
    assert abort_of(raw.exchange(bytes([0xA3]))) == 0x05040001  # start with no transfer
    assert abort_of(raw.exchange(bytes([0xC1]))) == 0x05040001  # end download, none open
    assert raw.exchange(bytes([0xA0]) + struct.pack("<HBBB", 0x1008, 0, 2, 0))[0] == 0xC2  # no CRC asked
    raw.send(bytes([0xA3]))
    assert [raw.recv()[0] for _ in range(2)] == [0x01, 0x02]
    assert abort_of(raw.exchange(bytes([0xA2, 3, 127]))) == 0x05040003  # ack of a segment never sent
    assert dev.stats.callback_errors == 0 and dev.read("theta1") == 0.0


def test_block_upload_partial_acknowledge_resends_the_rest(lab):
    """The client acknowledges 1 of 3 segments: the next sub-block starts with the second one."""
    lab.device("master")
    raw = Raw(lab)
    name = b"telethermo master"
    assert raw.exchange(bytes([0xA4]) + struct.pack("<HBBB", 0x1008, 0, 127, 0)) == pad(
        bytes([0xC6]) + struct.pack("<HBL", 0x1008, 0, 17)
    )
    raw.send(bytes([0xA3]))
    assert [raw.recv() for _ in range(3)] == [
        b"\x01" + name[:7],
        b"\x02" + name[7:14],
        pad(b"\x83" + name[14:]),
    ]
    raw.send(bytes([0xA2, 1, 127]))
    assert [raw.recv() for _ in range(2)] == [b"\x01" + name[7:14], pad(b"\x82" + name[14:])]
    end = raw.exchange(bytes([0xA2, 2, 127]))
    assert end == pad(bytes([0xC1 | 4 << 2]) + struct.pack("<H", crc16(name)))  # 4 bytes of the last unused
    raw.send(bytes([0xA1]))
    assert raw.silent()


def test_a_silent_client_gets_abort_0x05040000_and_the_channel_is_free_again(lab):
    dev = lab.device("master")
    raw = Raw(lab)
    dev.SDO_BLOCK_TIMEOUT_S = 0.05
    _initiate_download(raw, 8)
    raw.send(bytes([0x01]) + bits(1.0)[:7])
    assert abort_of(raw.recv(5.0)) == 0x05040000  # the client stopped sending
    assert raw.exchange(bytes([0xA4]) + struct.pack("<HBBB", 0x1008, 0, 127, 0))[0] == 0xC6
    raw.send(bytes([0xA3]))
    assert [raw.recv()[0] for _ in range(3)] == [0x01, 0x02, 0x83]
    assert abort_of(raw.recv(5.0)) == 0x05040000  # no acknowledge
    assert raw.silent()  # 0x40 is an upload request again, not a segment
    node = lab.client("master")
    assert node.sdo[0x1008].raw == "telethermo master" and dev.read("theta1") == 0.0


def test_a_client_abort_or_an_nmt_reset_ends_a_block_download(lab):
    dev = lab.device("master")
    raw = Raw(lab)
    _initiate_download(raw, 8)
    raw.send(bytes([0x01]) + bits(5.0)[:7])
    raw.send(struct.pack("<BHBL", 0x80, *THETA1, 0x05040000))  # abort by the client: no answer
    assert raw.silent()
    _initiate_download(raw, 8)
    raw.send(bytes([0x01]) + bits(5.0)[:7])
    raw.bus.send(can.Message(arbitration_id=0, data=bytes([0x81, 1]), is_extended_id=False))  # reset node
    assert lab.recv_until(raw.bus, lambda m: m.arbitration_id == 0x701) is not None  # boot-up
    assert raw.silent()
    assert dev.read("theta1") == 0.0 and dev.stats.callback_errors == 0


def test_protocol_switch_threshold_gives_a_normal_upload(lab):
    """pst > 0 and the data no longer than pst: the server switches to the normal upload (CiA 301 allows
    it); canopen's server answers. pst smaller than the data or 0: block upload."""
    lab.device("master")
    raw = Raw(lab)
    reply = raw.exchange(bytes([0xA4]) + struct.pack("<HBBB", 0x1000, 0, 127, 4))  # U32, pst 4
    assert reply[0] == 0x43 and reply[1:4] == bytes([0x00, 0x10, 0x00])  # expedited, 4 bytes
    reply = raw.exchange(bytes([0xA4]) + struct.pack("<HBBB", 0x1008, 0, 127, 17))  # 17 bytes, pst 17
    assert reply == pad(bytes([0x41]) + struct.pack("<HBL", 0x1008, 0, 17))  # segmented initiate
    data = b""
    for toggle in (0x60, 0x70, 0x60):
        seg = raw.exchange(bytes([toggle]))
        data += seg[1 : 8 - ((seg[0] >> 1) & 7)]
    assert data == b"telethermo master" and seg[0] & 1
    assert raw.exchange(bytes([0xA4]) + struct.pack("<HBBB", 0x1008, 0, 127, 16))[0] == 0xC6  # block
    raw.send(struct.pack("<BHBL", 0x80, 0x1008, 0, 0x05040000))


# ---------------------------------------------------------------------------- the state machine alone
def test_crc16_is_the_cia301_crc():
    assert crc16(b"123456789") == 0x31C3  # CRC-16/XMODEM check value: x^16+x^12+x^5+1, init 0
    ref = CrcXmodem()
    ref.process(b"telethermo master")
    assert crc16(b"telethermo master") == ref.final() and crc16(b"") == 0


class _Store:
    def __init__(self, data: bytes = b""):
        self.data, self.writes = data, []

    def read(self, index, sub):
        return self.data

    def write(self, index, sub, data):
        self.data = data
        self.writes.append(data)


def _client_download(server: BlockServer, payload: bytes, lose: set[int] = frozenset()) -> list[bytes]:
    """A client per CiA 301 for the pure server; ``lose``: absolute segment numbers dropped once."""
    segs = [payload[i : i + 7] for i in range(0, len(payload), 7)]
    (r,) = server.on_request(pad(bytes([0xC6]) + struct.pack("<HBL", 0x2000, 0, len(payload))))
    assert r[0] == 0xA4
    blk, pos, acks, lost = r[4], 0, [], set(lose)
    while pos < len(segs):
        sent = segs[pos : pos + blk]
        reply = []
        for i, seg in enumerate(sent, start=1):
            last = pos + i == len(segs)
            if pos + i in lost:
                lost.discard(pos + i)
                continue
            reply += server.on_request(pad(bytes([i | (0x80 if last else 0)]) + seg))
        (ack,) = reply
        assert ack[0] == 0xA2
        acks.append(ack)
        pos += ack[1]
        blk = ack[2]
    n = -len(payload) % 7
    return acks + server.on_request(pad(bytes([0xC1 | n << 2]) + struct.pack("<H", crc16(payload))))


def test_pure_block_download_of_several_full_blocks_with_a_lost_segment():
    payload = bytes((i * 37) & 0xFF for i in range(3 * 127 * 7 + 10))  # 3 full blocks and a bit
    store = _Store()
    frames = _client_download(BlockServer(store.read, store.write), payload, lose={200})
    assert [(f[1], f[2]) for f in frames[:-1]] == [(127, 127), (72, 127), (127, 127), (57, 127)]
    assert frames[-1] == pad(b"\xa1") and store.writes == [payload]


def test_pure_block_upload_of_several_full_blocks():
    payload = bytes((i * 11) & 0xFF for i in range(2 * 127 * 7 + 3))
    server = BlockServer(_Store(payload).read, _Store().write)
    (r,) = server.on_request(pad(bytes([0xA4]) + struct.pack("<HBBB", 0x2000, 0, 127, 0)))
    assert r == pad(bytes([0xC6]) + struct.pack("<HBL", 0x2000, 0, len(payload)))
    got, frames = b"", server.on_request(pad(b"\xa3"))
    blocks = 0
    while True:
        assert [f[0] & 0x7F for f in frames] == list(range(1, len(frames) + 1))
        got += b"".join(f[1:] for f in frames)
        blocks += 1
        last = frames[-1][0] & 0x80
        frames = server.on_request(pad(bytes([0xA2, len(frames), 127])))
        if last:  # the segment with c is acknowledged: the next frame is the end
            break
    assert blocks == 3
    (end,) = frames
    n = (end[0] >> 2) & 7
    assert n == 4 and got[: len(got) - n] == payload
    assert struct.unpack_from("<H", end, 1)[0] == crc16(payload)
    assert server.on_request(pad(b"\xa1")) == [] and server.direction is None
