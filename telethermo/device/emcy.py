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
- One error code may be held by several *sources* (the device's heartbeat consumer per watched node,
  its PDO-length check, the application): the code stays active, and 0x1001 keeps its bits, until
  every source that raised it has cleared it. A source raising a code another source already holds
  is the same error still present: no second frame, no second history entry (CANopenNode reports an
  error only when its status bit was not yet set).
- Unless the two concern different things: a raise may name its *subject* (the heartbeat consumer: the
  node it lost). A source raising a code held by other sources for other subjects only is a new
  occurrence (its own frame and history entry): one EMCY 0x8130 per lost node, even while the program's
  peer_lost trip (subject: the peer) holds 0x8130. No subject (None) is the same error as any subject.
"""

from __future__ import annotations

import struct
from collections import deque

HISTORY_LEN = 8

# error register bits (CiA 301 7.5.2.2)
REG_GENERIC, REG_CURRENT, REG_VOLTAGE, REG_TEMPERATURE = 0x01, 0x02, 0x04, 0x08
REG_COMMUNICATION, REG_PROFILE, REG_MANUFACTURER = 0x10, 0x20, 0x80

APP = "app"
"""The source of errors raised through the device's public ``raise_emcy`` (the node program)."""


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
    """Active errors (with the sources holding them), the error register and the history; pure
    bookkeeping (no I/O)."""

    def __init__(self) -> None:
        self.active: dict[int, int] = {}  # code -> register bits
        self.sources: dict[int, set[str]] = {}  # code -> the sources holding it
        self.subjects: dict[tuple[int, str], int | None] = {}  # (code, source) -> what it concerns
        self.history: deque[int] = deque(maxlen=HISTORY_LEN)  # newest first (0x1003 sub 1 = [0])

    @property
    def register(self) -> int:
        reg = 0
        for bits in self.active.values():
            reg |= bits
        return reg

    def raise_error(
        self,
        code: int,
        info16: int = 0,
        extra_bits: int = 0,
        *,
        source: str = APP,
        subject: int | None = None,
    ) -> bool:
        """``source`` raises ``code`` about ``subject`` (e.g. a lost node's ID; None: unspecified). True: a
        new occurrence (history entry, EMCY frame to send); False: another source already holds the code
        for the same subject (the same error still present: nothing to send)."""
        if not 0x0100 <= code <= 0xFFFF:
            raise ValueError(f"EMCY code must be in 0x0100..0xFFFF (0x00xx is 'no error'), got 0x{code:04X}")
        holders = self.sources.setdefault(code, set())
        shared = source not in holders and any(
            _same(self.subjects.get((code, other)), subject) for other in holders
        )
        holders.add(source)
        self.subjects[(code, source)] = subject
        self.active[code] = self.active.get(code, 0) | register_bits(code) | extra_bits
        if shared:
            return False
        self.history.appendleft((code & 0xFFFF) | ((info16 & 0xFFFF) << 16))
        return True

    def holds(self, code: int, source: str) -> bool:
        return source in self.sources.get(code, ())

    def clear(self, code: int, *, source: str = APP) -> bool:
        """``source`` no longer has ``code``; the code stays active while another source holds it.
        True if that left no active error at all (time for an error-reset EMCY)."""
        holders = self.sources.get(code)
        if not holders or source not in holders:
            return False
        holders.discard(source)
        self.subjects.pop((code, source), None)
        if holders:
            return False
        del self.sources[code]
        self.active.pop(code, None)
        return not self.active

    def clear_source(self, source: str) -> bool:
        """Every code ``source`` holds is cleared (e.g. a heartbeat consumer entry removed); True if
        that left no active error."""
        cleared = [code for code, holders in self.sources.items() if source in holders]
        return any([self.clear(code, source=source) for code in cleared])

    def clear_all(self) -> bool:
        had = bool(self.active)
        self.active.clear()
        self.sources.clear()
        self.subjects.clear()
        return had


def _same(a: int | None, b: int | None) -> bool:
    """Two subjects of one code name the same error (None: unspecified, the same as any)."""
    return a is None or b is None or a == b


def frame(code: int, register: int, data: bytes = b"") -> bytes:
    """The 8-byte EMCY payload."""
    return struct.pack("<HB5s", code & 0xFFFF, register & 0xFF, bytes(data[:5]))
