"""CAN traffic for the log-reading tests: what a running pair puts on the bus, as python-can messages."""

from __future__ import annotations

import struct
from typing import Iterator

import can


def pair_frames(n: int) -> Iterator[can.Message]:
    """n cycles of SYNC + both TPDO1 (estimate_C, Q_W), 10 ms apart."""
    for k in range(n):
        t = 1000.0 + 0.01 * k
        yield can.Message(timestamp=t, arbitration_id=0x080, data=bytes([k % 240 + 1]), is_extended_id=False)
        for nid in (1, 2):
            yield can.Message(
                timestamp=t + 0.001 * nid,
                arbitration_id=0x180 + nid,
                data=struct.pack("<ff", 30.0 + 0.01 * k, -0.1 * nid),
                is_extended_id=False,
            )
