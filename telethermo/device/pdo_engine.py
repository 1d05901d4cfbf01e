"""PDO service of a device: the channels' plans (:mod:`.pdo`) rebuilt on every parameter write, RPDOs
into the OD (at the next SYNC if synchronous), TPDOs on SYNC, on trigger and on the event timer, and
the NMT rules (PDOs only in OPERATIONAL). A frame whose length differs from the mapping is counted as
malformed, ignored, and raises EMCY 0x8210/0x8220 once until a frame of the right length comes.

RPDO timeout (CiA 301 RPDO event timer, 0x1400+n sub 5, ms; 0 = off): as CANopenNode, monitoring of a
channel starts at its first RPDO received in OPERATIONAL; no RPDO within the event time after the last
one raises EMCY 0x8250 (data byte 0: the RPDO number; source ``rpdo-timeout<n>``) once, and the next
RPDO clears it. Leaving OPERATIONAL stops the monitoring (the error stays until an RPDO or a reset);
making the channel invalid or setting its event timer to 0 removes the error. The node program's own
peer trip (peer_pdo_miss_limit, heartbeat loss) is independent of it."""

from __future__ import annotations

import functools
import threading
from typing import Callable

from canopen import SdoAbortedError

from telethermo.device import pdo as pdo_mod
from telethermo.cia301 import (
    ABORT_PDO_TOO_LONG,
    ABORT_UNSUPPORTED_ACCESS,
    EMCY_PDO_LENGTH,
    EMCY_PDO_LENGTH_EXCEEDED,
    EMCY_RPDO_TIMEOUT,
)
from telethermo.device.context import DeviceCore, FrameCallback, NmtState
from telethermo.device.emcy_producer import EmcyProducer
from telethermo.device.events import RpdoEvent
from telethermo.device.frames import FrameWatch


class PdoEngine:
    """Every TPDO and RPDO channel the object dictionary has (``tpdos``/``rpdos`` by number, 1-based)."""

    def __init__(
        self,
        core: DeviceCore,
        emcy: EmcyProducer,
        watch: FrameWatch,
        last_sync_counter: Callable[[], int | None],
    ):
        self.core = core
        self.emcy = emcy
        self.watch = watch
        self.last_sync_counter = last_sync_counter
        od = core.node.object_dictionary
        self.tpdos: dict[int, pdo_mod.PdoPlan] = {}
        self.rpdos: dict[int, pdo_mod.PdoPlan] = {}
        for i in range(512):
            if 0x1800 + i in od and 0x1A00 + i in od:
                self.tpdos[i + 1] = pdo_mod.PdoPlan(i + 1, True, 0x1800 + i, 0x1A00 + i)
            if 0x1400 + i in od and 0x1600 + i in od:
                self.rpdos[i + 1] = pdo_mod.PdoPlan(i + 1, False, 0x1400 + i, 0x1600 + i)
        self.sync_tpdos: list[pdo_mod.PdoPlan] = []
        self.sync_rpdos: list[pdo_mod.PdoPlan] = []
        self.listeners: list[Callable[[RpdoEvent], None]] = []
        self._subs: list[tuple[int, FrameCallback]] = []
        self._counts: dict[int, int] = {n: 0 for n in self.rpdos}
        # one condition per RPDO channel (one lock): a waiter for channel n (the lockstep producer waits for
        # the last synchronous one) is woken by that channel's PDO only, not by every RPDO of the cycle
        self._count_lock = threading.Lock()
        self._conds = {n: threading.Condition(self._count_lock) for n in self.rpdos}

    # ------------------------------------------------------------------ configuration
    def param_written(self, index: int, sub: int, value: int, old: bytes | None) -> None:
        """SDO write to a PDO communication or mapping parameter (0x1400..0x1BFF): CiA 301's rules,
        then the plans are rebuilt (an SdoAbortedError refuses the write)."""
        tx = index >= 0x1800
        is_map = (0x1600 <= index <= 0x17FF) or index >= 0x1A00
        plan = (self.tpdos if tx else self.rpdos).get((index & 0x1FF) + 1)
        if plan is None:
            return
        if not is_map:
            pdo_mod.check_comm_write(
                plan, sub, int(value)
            )  # ``plan`` still holds the values before this write
        elif plan.valid or (sub > 0 and self.core.u(plan.map_index, 0) != 0):
            # CiA 301 7.5.2.36 mapping procedure: PDO invalid (COB-ID bit 31), sub 0 to 0, the entries, sub 0
            # to their count, PDO valid; a write out of that order is refused as CANopenNode does (0x06010000)
            raise SdoAbortedError(ABORT_UNSUPPORTED_ACCESS)
        elif sub > 0 and value:
            pdo_mod.mappable(self.core.node, value >> 16, (value >> 8) & 0xFF, value & 0xFF, tx=tx)
        elif sub == 0 and value > 8:
            raise SdoAbortedError(ABORT_PDO_TOO_LONG)
        self.reconfigure()

    def reconfigure(self) -> None:
        """Rebuild every plan from the OD, resubscribe the RPDOs, re-arm the event timers."""
        core = self.core
        self.unsubscribe()
        for plan in list(self.tpdos.values()) + list(self.rpdos.values()):
            pdo_mod.compile_plan(plan, core.store, core.node)
            if plan.tx and 1 <= plan.trans_type <= 240:
                plan.countdown = (
                    min(plan.countdown, plan.trans_type) if plan.countdown > 0 else plan.trans_type
                )
        self.sync_tpdos = [p for p in self.tpdos.values() if p.valid and p.trans_type <= 240]
        self.sync_rpdos = [p for p in self.rpdos.values() if p.valid and p.trans_type <= 240]
        for plan in self.rpdos.values():
            if plan.valid:
                self._subs.append(core.subscribe(plan.cob_id, functools.partial(self._on_rpdo_frame, plan)))
        self.watch.set_pdo_cobids(
            p.cob_id for p in list(self.tpdos.values()) + list(self.rpdos.values()) if p.valid
        )
        if core.state == NmtState.OPERATIONAL:
            for tp in self.tpdos.values():
                self._arm_event_timer(tp)
        for rp in self.rpdos.values():
            self._arm_rpdo_timeout(rp)

    def unsubscribe(self) -> None:
        for cob, cb in self._subs:
            self.core.unsubscribe(cob, cb)
        self._subs = []

    def nmt_changed(self, old: NmtState, new: NmtState) -> None:
        """PDOs follow NMT: pending RPDO data dropped outside OPERATIONAL; on entering OPERATIONAL the
        SYNC countdowns start over (from the SYNC start value when the SYNC has a counter)."""
        if new != NmtState.OPERATIONAL or old != NmtState.OPERATIONAL:
            for rp in self.rpdos.values():
                rp.pending = None
        if new == NmtState.OPERATIONAL and old != NmtState.OPERATIONAL:
            overflow = self.core.u(0x1019, 0)
            for tp in self.tpdos.values():
                tp.countdown = tp.trans_type if 1 <= tp.trans_type <= 240 else 0
                tp.waiting_start = bool(tp.sync_start and overflow)
                tp.triggered = False
                self._arm_event_timer(tp)
        if new != NmtState.OPERATIONAL:
            self.core.scheduler.cancel_prefix("tpdo")
            self.core.scheduler.cancel_prefix("rpdo-timeout")
            for rp in self.rpdos.values():
                rp.last_rx = None  # monitoring starts again at the first RPDO in OPERATIONAL

    # ------------------------------------------------------------------ RPDO
    def _on_rpdo_frame(
        self, plan: pdo_mod.PdoPlan, can_id: int, data: bytes | bytearray, timestamp: float
    ) -> None:
        core = self.core
        if core.extended:
            return  # a 29-bit ID is no service of ours (counted as unknown)
        if core.state != NmtState.OPERATIONAL:
            core.stats.rpdo_ignored += 1
            return
        if len(data) != plan.length:
            core.stats.malformed_frames += 1
            if not plan.bad_length:
                plan.bad_length = True
                code = EMCY_PDO_LENGTH if len(data) < plan.length else EMCY_PDO_LENGTH_EXCEEDED
                self.emcy.raise_error(code, data=bytes([plan.number]), source=f"pdo-length{plan.number}")
            return
        data = bytes(data)
        with core.lock:
            if plan.synchronous:
                plan.pending = data
            else:
                plan.unpack_into_store(data)
            core.stats.rpdo_count += 1
        if plan.bad_length:
            plan.bad_length = False
            for code in (EMCY_PDO_LENGTH, EMCY_PDO_LENGTH_EXCEEDED):
                self.emcy.clear(code, source=f"pdo-length{plan.number}")
        if plan.event_timer_ms:
            self._rpdo_received(plan)
        cond = self._conds[plan.number]
        with cond:
            self._counts[plan.number] += 1
            cond.notify_all()
        if self.listeners:
            core.call(
                self.listeners, RpdoEvent(plan.number, plan.decode(data), self.last_sync_counter(), timestamp)
            )

    # ------------------------------------------------------------------ RPDO timeout (event timer)
    def _rpdo_received(self, plan: pdo_mod.PdoPlan) -> None:
        """An RPDO of a monitored channel: its deadline moves, an outstanding timeout is cleared."""
        core = self.core
        with core.lock:
            plan.last_rx = core.clock()
            self._arm_rpdo_timeout(plan)
            if plan.timed_out:
                plan.timed_out = False
                self.emcy.clear(EMCY_RPDO_TIMEOUT, source=f"rpdo-timeout{plan.number}")

    def _arm_rpdo_timeout(self, plan: pdo_mod.PdoPlan) -> None:
        """(Re)arm the channel's deadline after a reception or a parameter change; a channel no longer
        monitored (invalid, event timer 0) gives its timeout error back."""
        core = self.core
        key = f"rpdo-timeout{plan.number}"
        if not plan.valid or not plan.event_timer_ms:
            core.scheduler.cancel(key)
            plan.last_rx = None
            if plan.timed_out:
                plan.timed_out = False
                self.emcy.clear(EMCY_RPDO_TIMEOUT, source=key)
            return
        if plan.last_rx is not None and core.state == NmtState.OPERATIONAL:
            core.scheduler.set(
                key, plan.last_rx + plan.event_timer_ms * 1e-3, functools.partial(self._rpdo_timeout, plan)
            )

    def _rpdo_timeout(self, plan: pdo_mod.PdoPlan) -> None:
        """Scheduler job: no RPDO within the event time: EMCY 0x8250, once until the next RPDO."""
        core = self.core
        with core.lock:
            if (
                core.state != NmtState.OPERATIONAL
                or plan.last_rx is None
                or plan.timed_out
                or not plan.event_timer_ms
                or core.clock() < plan.last_rx + plan.event_timer_ms * 1e-3
            ):
                return  # not monitored any more, or an RPDO came meanwhile (it re-armed the job)
            plan.timed_out = True
            self.emcy.raise_error(
                EMCY_RPDO_TIMEOUT,
                data=bytes([plan.number]),
                source=f"rpdo-timeout{plan.number}",
                subject=plan.number,
            )

    def commit_sync_rpdos(self) -> tuple[int, ...]:
        """At a SYNC in OPERATIONAL: the synchronous RPDOs received since the previous SYNC go into the
        OD; their numbers."""
        fresh: tuple[int, ...] = ()
        for rp in self.sync_rpdos:
            if rp.pending is not None:
                rp.unpack_into_store(rp.pending)
                rp.pending = None
                fresh += (rp.number,)
        return fresh

    def rpdo_count(self, number: int = 1) -> int:
        """RPDOs of channel ``number`` accepted so far."""
        return self._counts[number]

    def wait_rpdo(self, number: int, *, after: int, timeout: float) -> bool:
        """Block until more than ``after`` RPDOs of channel ``number`` were accepted; False on timeout."""
        cond, counts = self._conds[number], self._counts
        with cond:
            return cond.wait_for(lambda: counts[number] > after, timeout)

    # ------------------------------------------------------------------ TPDO
    def send_sync_tpdos(self, counter: int | None) -> None:
        """At a SYNC in OPERATIONAL: the synchronous TPDOs that are due (type 0 when triggered, type n
        every n-th SYNC, after the SYNC start value if one is set)."""
        for tp in self.sync_tpdos:
            if tp.trans_type == 0:
                if tp.triggered:
                    tp.triggered = False
                    self._send(tp)
                continue
            if tp.waiting_start:
                if counter != tp.sync_start:
                    continue
                tp.waiting_start = False
                tp.countdown = 1
            tp.countdown -= 1
            if tp.countdown <= 0:
                tp.countdown = tp.trans_type
                self._send(tp)

    def trigger(self, number: int) -> None:
        """Event for TPDO ``number``: type 0 goes at the next SYNC, types 254/255 now
        (inhibit time permitting)."""
        tp = self.tpdos[number]
        if self.core.state != NmtState.OPERATIONAL or not tp.valid:
            return
        if tp.trans_type == 0:
            tp.triggered = True
        elif tp.trans_type >= 254:
            self._send_event_tpdo(tp)

    def _send_event_tpdo(self, tp: pdo_mod.PdoPlan) -> None:
        core = self.core
        if core.state != NmtState.OPERATIONAL or not tp.valid:
            return
        now = core.clock()
        allowed = tp.last_sent + tp.inhibit_100us * 1e-4
        if now < allowed:
            core.scheduler.set(f"tpdo-inhibit{tp.number}", allowed, lambda: self._send_event_tpdo(tp))
            return
        tp.last_sent = now
        self._send(tp)
        self._arm_event_timer(tp)

    def _arm_event_timer(self, tp: pdo_mod.PdoPlan) -> None:
        core = self.core
        if tp.valid and tp.trans_type >= 254 and tp.event_timer_ms and core.state == NmtState.OPERATIONAL:
            core.scheduler.set(
                f"tpdo-event{tp.number}",
                core.clock() + tp.event_timer_ms * 1e-3,
                lambda: self._send_event_tpdo(tp),
            )

    def _send(self, tp: pdo_mod.PdoPlan) -> None:
        self.core.send(tp.cob_id, tp.pack())
        self.core.stats.tpdo_sent += 1
