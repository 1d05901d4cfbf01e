"""Exact length on the wire of a classic CAN frame, stuff bits included (ISO 11898-1).

The stuffed region (SOF .. CRC) is built bit by bit with its real CRC-15, and a stuff bit is
counted after every 5 equal bits (the stuff bit itself counts towards the next run). The fixed tail
(CRC delimiter, ACK slot + delimiter, 7-bit EOF) and the 3-bit intermission are added unstuffed.
Error frames are counted at their minimum length (6 flag + 8 delimiter + 3 intermission bits): the
monitor cannot see how long the superposed flags were. CAN FD frames are not modelled: they are
counted as if classic with their DLC clipped to 8, and the monitor says so.
"""

from __future__ import annotations

import re

TAIL_BITS = 1 + 2 + 7 + 3  # CRC delimiter, ACK slot+delimiter, EOF, intermission
ERROR_FRAME_BITS = 6 + 8 + 3


def _crc15_bitwise(bits: list[int]) -> int:
    """CRC-15/CAN (polynomial 0x4599, init 0) bit by bit: the definition."""
    crc = 0
    for b in bits:
        nxt = b ^ ((crc >> 14) & 1)
        crc = (crc << 1) & 0x7FFF
        if nxt:
            crc ^= 0x4599
    return crc


def _make_table() -> list[int]:
    table = []
    for byte in range(256):
        table.append(_crc15_bitwise([(byte >> (7 - i)) & 1 for i in range(8)]) if byte else 0)
    return table


_TABLE = _make_table()


def crc15(value: int, nbits: int) -> int:
    """CRC-15/CAN of the ``nbits``-bit message ``value`` (MSB first), a byte at a time.

    With init 0, leading zero bits do not change a CRC, so the message is left-padded to whole
    bytes and fed through a 256-entry table (the usual MSB-first table CRC)."""
    pad = (-nbits) % 8
    data = value.to_bytes((nbits + pad) // 8, "big")
    crc = 0
    for byte in data:
        crc = ((crc << 8) & 0x7FFF) ^ _TABLE[((crc >> 7) ^ byte) & 0xFF]
    return crc


def _crc15(bits: list[int]) -> int:
    v = 0
    for b in bits:
        v = (v << 1) | b
    return crc15(v, len(bits))


def _bits(value: int, n: int) -> list[int]:
    return [(value >> (n - 1 - i)) & 1 for i in range(n)]


def _region(can_id: int, data: bytes, extended: bool, remote: bool, dlc: int) -> tuple[int, int]:
    """(value, bit count) of SOF..data, MSB first."""
    if extended:
        v, n = (can_id >> 18) & 0x7FF, 12  # SOF (0) + ID-A
        v, n = (v << 2) | 0b11, n + 2  # SRR, IDE
        v, n = (v << 18) | (can_id & 0x3FFFF), n + 18
        v, n = (v << 3) | (int(remote) << 2), n + 3  # RTR, r1, r0
    else:
        v, n = can_id & 0x7FF, 12
        v, n = (v << 3) | (int(remote) << 2), n + 3  # RTR, IDE, r0
    v, n = (v << 4) | (dlc & 0xF), n + 4
    if not remote and data:
        d = data[:8]
        v, n = (v << (8 * len(d))) | int.from_bytes(d, "big"), n + 8 * len(d)
    return v, n


def frame_bits(
    can_id: int, data: bytes, *, extended: bool = False, remote: bool = False, dlc: int | None = None
) -> list[int]:
    """The stuffed region SOF..CRC of a classic CAN frame, before stuffing (list of 0/1)."""
    dlc = min(len(data) if dlc is None else dlc, 15)
    v, n = _region(can_id, data, extended, remote, dlc)
    return _bits(v, n) + _bits(crc15(v, n), 15)


def stuff_count(bits: list[int]) -> int:
    """Number of stuff bits a transmitter inserts into ``bits``."""
    return _stuff_runs("".join("1" if b else "0" for b in bits))


_RUNS = re.compile(r"0+|1+")


def _stuff_runs(s: str) -> int:
    """Stuff bits of a bit string, run by run: a run of L equal bits preceded by a stuff bit of the
    same value (carry 1) holds (carry + L) // 5 stuff bits, and hands a carry of 1 to the next run
    when its last bit completed a group of five (the stuff bit then has the next run's value)."""
    count = carry = 0
    for run in _RUNS.findall(s):
        total = carry + len(run)
        count += total // 5
        carry = 1 if total % 5 == 0 else 0
    return count


def frame_length_bits(
    can_id: int, data: bytes, *, extended: bool = False, remote: bool = False, dlc: int | None = None
) -> int:
    """Bits a classic CAN data/remote frame occupies on the bus, incl. stuffing and intermission."""
    dlc = min(len(data) if dlc is None else dlc, 15)
    v, n = _region(can_id, data, extended, remote, dlc)
    v, n = (v << 15) | crc15(v, n), n + 15
    return n + _stuff_runs(format(v, f"0{n}b")) + TAIL_BITS


def message_length_bits(msg) -> int:
    """Bits on the wire of a python-can ``can.Message`` (error frames at their minimum length)."""
    if getattr(msg, "is_error_frame", False):
        return ERROR_FRAME_BITS
    data = bytes(msg.data or b"")
    return frame_length_bits(
        msg.arbitration_id,
        data,
        extended=bool(msg.is_extended_id),
        remote=bool(msg.is_remote_frame),
        dlc=msg.dlc if msg.is_remote_frame else None,
    )
