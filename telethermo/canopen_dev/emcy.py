"""EMCY producer with the error register (0x1001) and the pre-defined error field (0x1003).

- ``raise_error(code)``: the error becomes active, 0x1001 gets the generic bit plus the bit of its
  class, 0x1003 gets the code as its newest entry (sub-index 1, older entries shift down, at most
  8 kept), and an EMCY frame (code, 0x1001, 5 bytes manufacturer data) is sent on 0x1014.
- ``clear_error(code)`` / ``reset()``: once no error is active, 0x1001 returns to 0 and an
  "error reset" EMCY (code 0x0000) is sent. The history 0x1003 is kept; an SDO write of 0 to
  0x1003 sub 0 clears it (any other value is refused with 0x06090030).
- Inhibit time 0x1015 (100 µs units): EMCYs closer together are delayed, not lost; a code already
  waiting is not queued twice.
- Only PRE-OPERATIONAL and OPERATIONAL send EMCY frames; in STOPPED the error is recorded
  (0x1001/0x1003) but no frame is sent.
"""
from __future__ import annotations

import struct
from collections import deque

HISTORY_LEN = 8

# error register bits (CiA 301 7.5.2.2)
REG_GENERIC, REG_CURRENT, REG_VOLTAGE, REG_TEMPERATURE = 0x01, 0x02, 0x04, 0x08
REG_COMMUNICATION, REG_PROFILE, REG_MANUFACTURER = 0x10, 0x20, 0x80

# codes the device layer itself raises
EMCY_HEARTBEAT = 0x8130          # life guard / heartbeat error (consumer timeout)
EMCY_PDO_LENGTH = 0x8210         # PDO not processed due to length error
EMCY_PDO_LENGTH_EXCEEDED = 0x8220


def register_bits(code: int) -> int:
    """Error-register bits of an error code (generic bit always set)."""
    bits = REG_GENERIC
    top = code >> 12
    if top == 0x2:
        bits |= REG_CURRENT
    elif top == 0x3:
        bits |= REG_VOLTAGE
    elif top == 0x4:
        bits |= REG_TEMPERATURE
    elif 0x8100 <= code <= 0x82FF:
        bits |= REG_COMMUNICATION
    elif code >> 8 == 0xFF:
        bits |= REG_MANUFACTURER
    return bits


class EmcyState:
    """Active errors, the error register and the history; pure bookkeeping (no I/O)."""

    def __init__(self) -> None:
        self.active: dict[int, int] = {}   # code -> register bits
        self.history: deque[int] = deque(maxlen=HISTORY_LEN)  # newest first (0x1003 sub 1 = [0])

    @property
    def register(self) -> int:
        reg = 0
        for bits in self.active.values():
            reg |= bits
        return reg

    def raise_error(self, code: int, info16: int = 0, extra_bits: int = 0) -> int:
        if not 0x0100 <= code <= 0xFFFF:
            raise ValueError(f"EMCY code must be in 0x0100..0xFFFF (0x00xx is 'no error'), got 0x{code:04X}")
        self.active[code] = register_bits(code) | extra_bits
        self.history.appendleft((code & 0xFFFF) | ((info16 & 0xFFFF) << 16))
        return self.register

    def clear(self, code: int) -> bool:
        """Forget ``code``; True if that left no active error (time for an error-reset EMCY)."""
        had = self.active.pop(code, None) is not None
        return had and not self.active

    def clear_all(self) -> bool:
        had = bool(self.active)
        self.active.clear()
        return had


def frame(code: int, register: int, data: bytes = b"") -> bytes:
    """The 8-byte EMCY payload."""
    return struct.pack("<HB5s", code & 0xFFFF, register & 0xFF, bytes(data[:5]))
