"""SYNC consumer of a device (0x1005, 0x1019): on each SYNC in PRE-OPERATIONAL or OPERATIONAL, commit
the synchronous RPDOs, run the SYNC handlers, send the due synchronous TPDOs. The producing side is
:mod:`.sync` (a node never receives its own SYNC: the producer ticks its own device).

A SYNC of the wrong length (CiA 301 7.2.5: DLC 1 with a counter when 0x1019 > 0, else DLC 0) is not
processed and raises EMCY 0x8240 "unexpected SYNC data length" (data byte 0: the length received), cleared
at once like an event (0x1003 keeps it), as CANopenNode does not process it either (CO_EM_SYNC_LENGTH)."""

from __future__ import annotations

from typing import Callable

from canopen import SdoAbortedError

from telethermo.cia301 import ABORT_DEVICE_STATE, ABORT_LOCAL_CONTROL, ABORT_RANGE, EMCY_SYNC_LENGTH
from telethermo.device.context import DeviceCore, FrameCallback, NmtState
from telethermo.device.emcy_producer import EmcyProducer
from telethermo.device.events import SyncTick
from telethermo.device.pdo_engine import PdoEngine


class SyncConsumer:
    """SYNC handling of one device."""

    def __init__(self, core: DeviceCore, pdos: PdoEngine, emcy: EmcyProducer):
        self.core = core
        self.pdos = pdos
        self.emcy = emcy
        self.wrong_length = 0
        """SYNC frames refused for their length."""
        self.handlers: list[Callable[[SyncTick], None]] = []
        self.last_counter: int | None = None
        self._sub: tuple[int, FrameCallback] | None = None

    @property
    def cob_id(self) -> int:
        return self.core.u(0x1005, 0) & 0x7FF

    @property
    def is_producer(self) -> bool:
        return bool(self.core.u(0x1005, 0) & (1 << 30))

    def resubscribe(self) -> None:
        """Listen on the COB-ID 0x1005 names (after a reset or a write of 0x1005)."""
        self.unsubscribe()
        self._sub = self.core.subscribe(self.cob_id, self._on_frame)

    def unsubscribe(self) -> None:
        if self._sub:
            self.core.unsubscribe(*self._sub)
            self._sub = None

    def cob_id_written(self, index: int, sub: int, value: int, old: bytes | None) -> None:
        """SDO write to 0x1005. A 29-bit SYNC is not supported (as in CANopenNode's OD_write_1005 /
        CO_ODF_1005: "only 11-bit CAN identifier is supported", 0x06090030): refused rather than
        keeping an 11-bit SYNC behind an OD that says 29-bit."""
        if value & (1 << 29):
            raise SdoAbortedError(ABORT_RANGE)
        self.resubscribe()

    def period_written(self, index: int, sub: int, value: int, old: bytes | None) -> None:
        """SDO write to 0x1006 (communication cycle period, µs). No SYNC of this device runs on a timer of
        its own: the schedule is the application's (``SyncProducer.transmit``; telethermo's node programs:
        lockstep, or real time at the control period that the controllers and models share), set by its
        configuration (network.toml ``[sync] period_s``, :class:`DeviceSettings` ``sync_period_us``). So
        0x1006 reports that value, and a write of another one is refused with 0x08000021 (data cannot be
        stored because of local control) rather than accepted and ignored; the same value is accepted."""
        if old is not None and value != int.from_bytes(old, "little"):
            raise SdoAbortedError(ABORT_LOCAL_CONTROL)

    def overflow_written(self, index: int, sub: int, value: int, old: bytes | None) -> None:
        """SDO write to 0x1019: 1 is no counter overflow value (0x06090030); CiA 301 allows a change
        only while the communication cycle period 0x1006 is 0 (CANopenNode's OD_write_1019:
        ODR_DATA_DEV_STATE, 0x08000022)."""
        if value == 1:
            raise SdoAbortedError(ABORT_RANGE)
        if self.core.u(0x1006, 0) != 0:
            raise SdoAbortedError(ABORT_DEVICE_STATE)

    def _on_frame(self, can_id: int, data: bytes | bytearray, timestamp: float) -> None:
        core = self.core
        if core.extended:
            return  # a 29-bit ID is no service of ours (counted as unknown)
        expected = 1 if 0x1019 in core.store and core.u(0x1019, 0) else 0
        if len(data) != expected:
            core.stats.malformed_frames += 1
            self.wrong_length += 1
            if core.state in (NmtState.OPERATIONAL, NmtState.PRE_OPERATIONAL):
                self.emcy.raise_error(EMCY_SYNC_LENGTH, data=bytes((len(data),)), source="sync")
                self.emcy.clear(EMCY_SYNC_LENGTH, source="sync")
            return
        self.process(data[0] if data else None)

    def process(self, counter: int | None) -> SyncTick | None:
        """Handle one SYNC: commit synchronous RPDOs, run the SYNC handlers, send the due TPDOs.
        Returns None in STOPPED/INITIALISING (SYNC ignored)."""
        core = self.core
        state = core.state
        if state is not NmtState.OPERATIONAL and state is not NmtState.PRE_OPERATIONAL:
            return None
        with core.lock:
            core.stats.sync_count += 1
            self.last_counter = counter
            operational = state is NmtState.OPERATIONAL
            fresh = self.pdos.commit_sync_rpdos() if operational else ()
            tick = SyncTick(counter, fresh, operational)
            for fn in self.handlers:
                try:
                    fn(tick)
                except Exception:
                    core.callback_failed(fn)
            if core.state is NmtState.OPERATIONAL:
                self.pdos.send_sync_tpdos(counter)
        return tick
