"""Segmented SDO transfers the way CANopenNode's server treats them (issue 25, protocol corners):
a download that cannot succeed is refused at its initiate, before the client sends any data, and a
transfer left open is aborted with 0x05040000 after the server timeout (as block transfers are).

Through canopen's SdoClient where it can say it, raw python-can frames where the exact frame order
matters (the abort answers the initiate itself; a late segment finds no transfer)."""

from __future__ import annotations

import struct

import can
import pytest
from canopen import SdoAbortedError

THETA1 = (0x2310, 1)  # REAL64, rw (8 bytes)
SDO_RX, SDO_TX = 0x601, 0x581


def abort_code(fn) -> int:
    with pytest.raises(SdoAbortedError) as exc:
        fn()
    return exc.value.code


def exchange(lab, bus, data: bytes, timeout: float = 2.0):
    """Send one request on 0x601, return the server's answer (8 bytes) or None."""
    bus.send(can.Message(arbitration_id=SDO_RX, data=data.ljust(8, b"\x00"), is_extended_id=False))
    msg = lab.recv_until(bus, lambda m: m.arbitration_id == SDO_TX, timeout)
    return None if msg is None else bytes(msg.data)


def initiate_download(index: int, sub: int, size: int | None) -> bytes:
    """Initiate segmented download (ccs 1, e = 0, s = size indicated)."""
    return bytes([0x21 if size is not None else 0x20]) + struct.pack("<HBL", index, sub, size or 0)


def aborted(answer: bytes | None) -> tuple[int, int, int] | None:
    """(index, sub, abort code) of an abort frame, else None."""
    if answer is None or answer[0] != 0x80:
        return None
    return struct.unpack_from("<HBL", answer, 1)


@pytest.mark.parametrize(
    "index, sub, size, code",
    [
        (0x2FFF, 0, 8, 0x06020000),  # no such object
        (0x2310, 0x7F, 8, 0x06090011),  # no such sub-index
        (0x2000, 0, 4, 0x06010002),  # T_sensor_C: read-only
        (0x1008, 0, 12, 0x06010002),  # device name: const
        (*THETA1, 12, 0x06070012),  # 12 bytes indicated for a REAL64
        (*THETA1, 5, 0x06070013),  # 5 bytes indicated for a REAL64
    ],
)
def test_a_segmented_download_that_cannot_succeed_is_refused_at_its_initiate(lab, index, sub, size, code):
    dev = lab.device("master")
    bus = lab.raw_bus()
    assert aborted(exchange(lab, bus, initiate_download(index, sub, size))) == (index, sub, code)
    # nothing is open: a segment now is no segment of any transfer
    assert aborted(exchange(lab, bus, b"\x00" + b"\x00" * 7))[2] == 0x05040001
    assert dev.read("theta1") == 0.0


def test_canopens_client_gets_the_initiate_refusals(lab):
    dev = lab.device("master")
    node = lab.client("master")
    assert abort_code(lambda: node.sdo.download(*THETA1, b"\x01" * 12, force_segment=True)) == 0x06070012
    assert abort_code(lambda: node.sdo.download(0x2FFF, 0, b"\x01" * 8, force_segment=True)) == 0x06020000
    assert abort_code(lambda: node.sdo.download(0x2000, 0, b"\x01" * 4, force_segment=True)) == 0x06010002
    node.sdo.download(*THETA1, struct.pack("<d", 2.5), force_segment=True)  # the right size: stored
    assert dev.read("theta1") == 2.5


def test_an_unsized_segmented_download_is_checked_at_the_end_as_before(lab):
    dev = lab.device("master")
    bus = lab.raw_bus()
    assert exchange(lab, bus, initiate_download(*THETA1, None))[0] == 0x60
    # 4 data bytes (n = 3 unused), last segment: 4 bytes for a REAL64
    assert aborted(exchange(lab, bus, bytes([0x01 | 3 << 1]) + b"\x00" * 7)) == (*THETA1, 0x06070010)
    assert dev.read("theta1") == 0.0


def test_a_download_left_open_is_aborted_with_0x05040000_and_a_late_segment_finds_no_transfer(lab):
    dev = lab.device("master")
    assert dev.SDO_SEGMENT_TIMEOUT_S == 1.0  # as the block transfers
    bus = lab.raw_bus()
    assert exchange(lab, bus, initiate_download(*THETA1, 8))[0] == 0x60
    answer = lab.recv_until(bus, lambda m: m.arbitration_id == SDO_TX, timeout=10.0)
    assert answer is not None and aborted(bytes(answer.data)) == (*THETA1, 0x05040000)
    # the client's segment after the abort belongs to no transfer
    assert aborted(exchange(lab, bus, bytes([0x01 | 6 << 1]) + b"\x40"))[2] == 0x05040001
    assert dev.read("theta1") == 0.0
    node = lab.client("master")  # the channel is free again
    node.sdo.download(*THETA1, struct.pack("<d", 1.5), force_segment=True)
    assert dev.read("theta1") == 1.5


def test_an_upload_left_open_is_aborted_too(lab):
    dev = lab.device("master")
    dev.SDO_SEGMENT_TIMEOUT_S = 0.3
    bus = lab.raw_bus()
    answer = exchange(lab, bus, bytes([0x40]) + struct.pack("<HB", 0x1008, 0))
    assert answer[0] == 0x41 and struct.unpack_from("<L", answer, 4)[0] == len("telethermo master")
    late = lab.recv_until(bus, lambda m: m.arbitration_id == SDO_TX, timeout=10.0)
    assert late is not None and aborted(bytes(late.data)) == (0x1008, 0, 0x05040000)
    assert aborted(exchange(lab, bus, bytes([0x60])))[2] == 0x05040001
