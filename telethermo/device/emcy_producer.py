"""EMCY producer service: 0x1001 / 0x1003 kept from the error bookkeeping (:mod:`.emcy`), EMCY frames on
0x1014 honouring the inhibit time 0x1015 (100 µs units: closer EMCYs are delayed, not lost), only in
PRE-OPERATIONAL and OPERATIONAL (in STOPPED the error is recorded, no frame is sent)."""

from __future__ import annotations

from canopen import SdoAbortedError

from telethermo.device import emcy as emcy_mod
from telethermo.cia301 import ABORT_RANGE, EMCY_NO_ERROR
from telethermo.device.context import SERVING, DeviceCore
from telethermo.device.pdo import PDO_INVALID


class EmcyProducer:
    """Errors by source, 0x1001/0x1003 and the EMCY frames of one device."""

    def __init__(self, core: DeviceCore):
        self.core = core
        self.errors = emcy_mod.EmcyState()
        self._queue: list[tuple[int, int, bytes]] = []
        self._last_sent = -1e18  # clock time of the last EMCY frame (s)

    def raise_error(
        self,
        code: int,
        *,
        data: bytes = b"",
        info16: int = 0,
        source: str = emcy_mod.APP,
        subject: int | None = None,
    ) -> None:
        """Record error ``code`` (0x1001, 0x1003) and send its EMCY; a code another source holds
        already for the same ``subject`` is the same error still present: no second frame or history
        entry (see :mod:`.emcy`)."""
        with self.core.lock:
            new = self.errors.raise_error(code, info16, source=source, subject=subject)
            self.store()
            if new:
                self._enqueue(code, self.errors.register, data)

    def clear(self, code: int, *, source: str = emcy_mod.APP) -> None:
        """``source`` no longer has ``code``; when no error is left, send the error-reset EMCY."""
        with self.core.lock:
            if self.errors.clear(code, source=source):
                self.store()
                self._enqueue(EMCY_NO_ERROR, self.errors.register, b"")
            else:
                self.store()

    def clear_all(self) -> None:
        """Clear every active error and send the error-reset EMCY (history 0x1003 is kept)."""
        with self.core.lock:
            if self.errors.clear_all():
                self.store()
                self._enqueue(EMCY_NO_ERROR, 0, b"")

    def holds(self, code: int, source: str) -> bool:
        return self.errors.holds(code, source)

    @property
    def active(self) -> tuple[int, ...]:
        return tuple(self.errors.active)

    def reset(self, whole: bool | None) -> None:
        """An NMT reset: node (``whole``) forgets every error; communication clears the history and
        re-stores 0x1001; power-on (None) keeps both. Queued EMCYs are dropped either way."""
        if whole:
            self.errors = emcy_mod.EmcyState()
        elif whole is not None:
            self.errors.history.clear()
            self.core.store[0x1001][0] = bytes([self.errors.register])
        self._queue.clear()
        self.core.scheduler.cancel("emcy")

    def history_written(self, index: int, sub: int, value: int, old: bytes | None) -> None:
        """SDO write to 0x1003: 0 to sub 0 clears the history; anything else is refused (0x06090030)."""
        if sub != 0 or value != 0:
            raise SdoAbortedError(ABORT_RANGE)
        self.errors.history.clear()
        self.store()

    def store(self) -> None:
        """0x1001 and 0x1003 from the bookkeeping."""
        store = self.core.store
        store[0x1001][0] = bytes([self.errors.register])
        hist = list(self.errors.history)
        store[0x1003][0] = bytes([len(hist)])
        for s in range(1, 9):
            if s in store[0x1003]:
                store[0x1003][s] = (hist[s - 1] if s <= len(hist) else 0).to_bytes(4, "little")

    def _enqueue(self, code: int, register: int, data: bytes) -> None:
        core = self.core
        if core.state not in SERVING:
            core.stats.emcy_suppressed += 1
            return
        inhibit = core.u(0x1015, 0) * 1e-4 if 0x1015 in core.store else 0.0
        now = core.clock()
        if self._queue or now < self._last_sent + inhibit:
            if all(c != code for c, _, _ in self._queue):
                self._queue.append((code, register, data))
            core.scheduler.set("emcy", max(now, self._last_sent + inhibit), self._flush)
            return
        self._send(code, register, data, now)

    def _send(self, code: int, register: int, data: bytes, now: float) -> None:
        cob = self.core.u(0x1014, 0)
        if cob & PDO_INVALID:
            return
        self._last_sent = now
        self.core.send(cob & 0x7FF, emcy_mod.frame(code, register, data))
        self.core.stats.emcy_sent += 1

    def _flush(self) -> None:
        core = self.core
        with core.lock:
            if not self._queue:
                return
            if core.state not in SERVING:
                core.stats.emcy_suppressed += len(self._queue)
                self._queue.clear()
                return
            code, register, data = self._queue.pop(0)
            now = core.clock()
            self._send(code, register, data, now)
            if self._queue:
                inhibit = core.u(0x1015, 0) * 1e-4
                core.scheduler.set("emcy", now + inhibit, self._flush)
