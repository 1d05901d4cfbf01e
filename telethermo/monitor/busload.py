"""Exact length on the wire of a classic CAN frame, stuff bits included (ISO 11898-1).

The stuffed region (SOF .. CRC) is built bit by bit with its real CRC-15, and a stuff bit is
counted after every 5 equal bits (the stuff bit itself counts towards the next run). The fixed tail
(CRC delimiter, ACK slot + delimiter, 7-bit EOF) and the 3-bit intermission are added unstuffed.
Error frames are counted at their minimum length (6 flag + 8 delimiter + 3 intermission bits): the
monitor cannot see how long the superposed flags were. CAN FD frames are not modelled: they are
counted as if classic with their DLC clipped to 8, and the monitor says so.
"""
from __future__ import annotations

TAIL_BITS = 1 + 2 + 7 + 3          # CRC delimiter, ACK slot+delimiter, EOF, intermission
ERROR_FRAME_BITS = 6 + 8 + 3


def _crc15(bits: list[int]) -> int:
    crc = 0
    for b in bits:
        nxt = b ^ ((crc >> 14) & 1)
        crc = (crc << 1) & 0x7FFF
        if nxt:
            crc ^= 0x4599
    return crc


def _bits(value: int, n: int) -> list[int]:
    return [(value >> (n - 1 - i)) & 1 for i in range(n)]


def frame_bits(can_id: int, data: bytes, *, extended: bool = False, remote: bool = False,
               dlc: int | None = None) -> list[int]:
    """The stuffed region SOF..CRC of a classic CAN frame, before stuffing (list of 0/1)."""
    dlc = len(data) if dlc is None else dlc
    dlc = min(dlc, 15)
    if extended:
        bits = [0] + _bits(can_id >> 18, 11) + [1, 1] + _bits(can_id & 0x3FFFF, 18) + [int(remote), 0, 0]
    else:
        bits = [0] + _bits(can_id & 0x7FF, 11) + [int(remote), 0, 0]
    bits += _bits(dlc, 4)
    if not remote:
        for byte in data[:8]:
            bits += _bits(byte, 8)
    return bits + _bits(_crc15(bits), 15)


def stuff_count(bits: list[int]) -> int:
    """Number of stuff bits a transmitter inserts into ``bits``."""
    count, run, last = 0, 0, None
    for b in bits:
        if b == last:
            run += 1
        else:
            run, last = 1, b
        if run == 5:
            count += 1
            last, run = 1 - b, 1   # the stuff bit is the complement and starts a new run
    return count


def frame_length_bits(can_id: int, data: bytes, *, extended: bool = False, remote: bool = False,
                      dlc: int | None = None) -> int:
    """Bits a classic CAN data/remote frame occupies on the bus, incl. stuffing and intermission."""
    bits = frame_bits(can_id, data, extended=extended, remote=remote, dlc=dlc)
    return len(bits) + stuff_count(bits) + TAIL_BITS


def message_length_bits(msg) -> int:
    """Bits on the wire of a python-can ``can.Message`` (error frames at their minimum length)."""
    if getattr(msg, "is_error_frame", False):
        return ERROR_FRAME_BITS
    data = bytes(msg.data or b"")
    return frame_length_bits(msg.arbitration_id, data, extended=bool(msg.is_extended_id),
                             remote=bool(msg.is_remote_frame),
                             dlc=msg.dlc if msg.is_remote_frame else None)
