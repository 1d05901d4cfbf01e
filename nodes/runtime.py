"""The node runtime shared by the master and the slave: a CANopen device (telethermo.device)
on a python-can bus, a rig, the control core, the peer link and the recording, composed of one part
per concept:

- :mod:`nodes.param_slot`: the parameter book and the parameters the controller runs (SDO writes taken
  at the next SYNC);
- :mod:`nodes.model_slot`: the TEM model and its objects (model_command);
- :mod:`nodes.ident_service`: the identification experiment's progress and samples;
- :mod:`nodes.cycle`: the control cycle on each SYNC (rig, peer values, peer policy, core step, OD,
  EMCY, recording);
- :mod:`nodes.fallback`: local cycles when the SYNC producer is gone;
- :mod:`nodes.producer`: the SYNC producer's schedule (lockstep or real time).

Peer loss (heartbeat timeout, or more than ``peer_pdo_miss_limit`` cycles without its PDO) makes the
core's peer values ``alive=False``: the envelope ramps to neutral and cuts, EMCY 0x8130. When the peer
is back (fresh PDOs, heartbeat seen) and only peer trips are latched, the node clears them
(telethermo.control.peer_policy): the core resumes bumplessly. Other trips stay latched for the operator.

The SYNC producer (master by default) is the NMT master of the pair: it starts every node that reports
a boot-up or a pre-operational heartbeat. The decisions are :mod:`nodes.nmt_policy`'s; this module carries
them out.
"""

from __future__ import annotations

import dataclasses
import logging
import threading
import time
from pathlib import Path
from typing import Callable

import canopen

from telethermo.device.device import Device, NmtCommand, NmtState, PeerEvent, SyncTick, WriteEvent
from telethermo.device.storage import default_store_path
from telethermo.device.netconfig import NetworkConfig
from telethermo.device.sync import SyncProducer
from telethermo.control.types import Mode, Role
from telethermo.iomodule.rigconfig import RigConfig
from telethermo.recording.journal import CsvRecorder
from telethermo.transport.bus import TransportSettings
from telethermo.transport.resilient import ResilientBus

from telethermo.nodes.bus_outage import BusOutage
from telethermo.nodes.cycle import MAX_TIMING_SAMPLES, ControlCycle
from telethermo.nodes.fallback import FallbackCycles
from telethermo.nodes.ident_service import IdentService
from telethermo.nodes.model_slot import ModelSlot
from telethermo.nodes.nmt_policy import on_own_nmt, on_peer_event
from telethermo.nodes.param_slot import ParamSlot
from telethermo.nodes.parts import NodeParts
from telethermo.nodes.peer import PeerLink
from telethermo.nodes.producer import run_producer, wait_for_peer
from telethermo.nodes.schedule import RealtimeTicker, SyncNumbering
from telethermo.nodes.stats import RuntimeStats
from telethermo.nodes.store_slot import StoreSlot
from telethermo.nodes.sync_anchor import read_producer_sync_count

log = logging.getLogger("telethermo.node")

LOCKSTEP_INDEX = 0x2704
#: a SYNC consumer at start waits this long for a SYNC to tell whether the producer runs already, s
ANCHOR_WAIT_S = 0.25


class NodeRuntime:
    """One node process's machinery. ``start()``, then ``run_producer(...)`` or ``wait()``,
    then ``stop()``."""

    def __init__(
        self,
        role: Role,
        node_id: int,
        net: NetworkConfig,
        transport: TransportSettings,
        parts: NodeParts,
        *,
        mode: Mode,
        lockstep: bool,
        produce_sync: bool,
        recorder: CsvRecorder | None = None,
        record_timing: bool = True,
        store_path: Path | None = None,
    ) -> None:
        self.role = role
        self.prefix = "m" if role is Role.MASTER else "s"
        self.node_id = node_id
        self.net = net
        self.transport = transport
        self.parts = parts
        self.lockstep = lockstep
        self.produce_sync = produce_sync
        self.recorder = recorder
        self.record_timing = record_timing
        self.peer_id = net.peer(role).node_id
        self.stats = RuntimeStats()
        self.stop_event = threading.Event()
        self.settings = ParamSlot(parts=parts, role=role, mode=mode, peer=lambda: self.peer)
        self.models = ModelSlot(
            parts=parts,
            settings=self.settings,
            node_id=node_id,
            swap_model=lambda tem, neutral_C: self.cycle.swap_model(tem, neutral_C),
        )
        self.ident = IdentService(self.settings, self.stats)
        self.store = StoreSlot(
            settings=self.settings,
            models=self.models,
            period_s=parts.period_s,
            node_id=node_id,
            path=store_path if store_path is not None else default_store_path(node_id),
        )
        self.cycle = ControlCycle(self)
        self.bus_outage = BusOutage(
            peer=lambda: self.peer,
            peer_id=self.peer_id,
            start_fallback=None if produce_sync else lambda: self.fallback.start(),
        )
        self.fallback = FallbackCycles(
            cycle=self.cycle,
            bus_outage=self.bus_outage,
            stats=self.stats,
            stop_event=self.stop_event,
            safe_current=self.safe_current,
            period_s=parts.period_s,
            peer_id=self.peer_id,
        )
        self.bus: ResilientBus | None = None
        self.sync_cycle = -1
        """The SYNC cycle being run: SYNCs numbered from 0 by unwrapping the SYNC counter
        (both nodes alike)."""
        self._sync_numbering = SyncNumbering(None)
        self.network: canopen.Network | None = None
        self.device: Device | None = None
        self.sync: SyncProducer | None = None
        self.peer = PeerLink()
        self.ticker: RealtimeTicker | None = None
        self.final_comments: Callable[[], list[str]] | None = None
        """Optional () -> comment lines that replace the recording's header at close (final meta)."""
        self.peer_boots = 0
        self.peer_pauses = 0
        """Changes of the peer between OPERATIONAL and STOPPED/PRE-OPERATIONAL reported by its heartbeat."""
        self.peer_paused = False  # the peer's heartbeat went from OPERATIONAL to STOPPED/PRE-OPERATIONAL
        self.nmt_leaves = 0  # how often this node left OPERATIONAL (its device drops PDOs outside it)
        self._waiting_first_rpdo = False
        self._sync_sent_at = 0.0
        self._w_current = None

    # ------------------------------------------------------------------ views
    @property
    def mode(self) -> Mode:
        """The mode the controller runs."""
        return self.settings.mode

    @property
    def model(self):
        """The TEM model the controller runs (the --model file at power-on; 0x230D loads another)."""
        return self.models.model

    @property
    def models_loaded(self) -> int:
        return self.models.loaded

    # ------------------------------------------------------------------ life cycle
    def start(self) -> None:
        """Open the bus, power the device on (boot-up, heartbeat), install the handlers. The bus is reopened
        by itself when it is lost (:mod:`nodes.bus_outage`)."""
        self.bus = bus = ResilientBus(self.transport, on_change=self.bus_outage.on_change)
        self.network = canopen.Network(bus)
        self.network.connect()
        settings = dataclasses.replace(self.net.device_settings(self.role), sync_producer=self.produce_sync)
        eds = self.net.node(self.role).eds
        dev = Device(self.network, self.node_id, eds, settings=settings)
        self.device = dev
        self.bus_outage.bind(dev)
        self.fallback.bind(dev)
        self.store.bind(dev)
        self.store.load(dev)  # stored communication values before anything reads them or the device starts
        dev.add_sync_handler(self._on_sync)
        self._sync_numbering = SyncNumbering(int(dev.read(0x1019)) if 0x1019 in dev.od else 0)
        if not self.produce_sync:  # SYNCs the device ignores (STOPPED) still count (recordings' sync_cycle)
            self.network.subscribe(dev.sync_cob_id, self._on_sync_frame_ignored)
            self._anchor_sync_numbering()
        if self.produce_sync and self.record_timing:
            dev.add_rpdo_listener(self._on_rpdo)
        dev.add_peer_listener(self._on_peer)
        self.network.subscribe(0x700 + self.peer_id, self.bus_outage.on_peer_heartbeat)
        dev.add_write_listener(self._on_write)
        dev.add_nmt_listener(self._on_nmt)
        self._w_current = dev.writer("current_A")
        watch = getattr(self.parts.rig, "watch_controller", None)
        if callable(watch):  # --rig io: restart a module that left OPERATIONAL while we run
            watch(lambda: (dev.state is NmtState.OPERATIONAL, not self.bus_outage.down))
        for part in (self.settings, self.models, self.ident, self.cycle):
            part.bind(dev)
        self._power_on()
        if self.produce_sync:
            self.sync = SyncProducer(dev)
        dev.start()
        log.info(
            "node %d (%s) on %s: pre-operational, heartbeat every %d ms, peer %d watched for %d ms",
            self.node_id,
            self.role,
            self.transport.describe(),
            int(dev.read(0x1017)),
            self.peer_id,
            self.net.heartbeat.consumer_ms,
        )

    def _anchor_sync_numbering(self) -> None:
        """Before the boot-up: if the SYNC producer runs already (a SYNC within 0.25 s; this node was
        restarted), number its SYNCs as it does (nodes.sync_anchor), not modulo the counter's wrap."""
        deadline = time.monotonic() + ANCHOR_WAIT_S
        while self._sync_numbering.number < 0 and time.monotonic() < deadline:
            time.sleep(0.01)
        if self._sync_numbering.number < 0:
            return  # no producer yet: its first SYNC will be number 0 here as there
        count = read_producer_sync_count(self.network, self.peer_id)
        if count:
            self._sync_numbering.anchor(count - 1)
            log.info(
                "SYNC producer %d has sent %d SYNCs: this node numbers them from there (now %d)",
                self.peer_id,
                count,
                self._sync_numbering.number,
            )

    def _power_on(self) -> None:
        """This program's power-on configuration into the controller and the OD; on start and after a reset
        node (the device has restored the EDS values: a fresh book, a fresh peer link)."""
        dev = self.device
        self.settings.power_on(dev, has_model=self.parts.model is not None)
        dev.write(LOCKSTEP_INDEX, bool(self.lockstep), check=False)
        self.models.power_on()
        self.settings.book.has_model = self.models.model is not None
        self.store.restore_application()  # the stored model and parameters (nodes.store_slot)
        self.peer = PeerLink(max_missed_cycles=self.settings.book.peer_miss_limit)
        self.ident.power_on()
        self.settings.write_image()
        self._fit_heartbeat_to_modules()

    def _fit_heartbeat_to_modules(self) -> None:
        """``--rig io``: the I/O modules watch this node's heartbeat and cut the drive when it stops
        (RIG.toml ``consumer_ms``). A period (network.toml's ``producer_ms``, or a stored 0x1017) longer than
        the rig's ``heartbeat_limit_ms`` (a third of the shortest watch) is lowered to it
        (:meth:`RigConfig.controller_heartbeat_ms`): with the packaged
        100 ms and 150 ms, one heartbeat 50 ms late was a module's loss."""
        config = getattr(self.parts.rig, "config", None)
        if not isinstance(config, RigConfig):
            return
        period = int(self.device.read(0x1017))
        limit = config.controller_heartbeat_ms(period)
        if limit == period:
            return
        self.device.write(0x1017, limit)
        log.info(
            "heartbeat every %d ms, not %d ms: a third of the shortest time this node's I/O modules watch it",
            limit,
            period,
        )

    def wait_for_peer(self, timeout_s: float) -> bool:
        """Wait until the peer's heartbeat is seen (it is started by NMT when it is)."""
        return wait_for_peer(self, timeout_s)

    def run_producer(self, cycles: int, *, progress_every: int = 0, progress=None) -> int:
        """Start all nodes (NMT) and run ``cycles`` SYNC cycles (0 = until stopped); return cycles run."""
        return run_producer(self, cycles, progress_every=progress_every, progress=progress)

    def mark_sync_sent(self) -> None:
        """The producer is about to send a SYNC: time the peer's first TPDO1 after it."""
        self._sync_sent_at = time.monotonic()
        self._waiting_first_rpdo = True

    def stop(self, reason: str = "stop") -> None:
        """Current to zero, last heartbeat, recording closed, bus released. Idempotent."""
        self.stop_event.set()
        dev = self.device
        try:
            if dev is not None:
                with dev.lock:  # no SYNC handler runs while we cut the current
                    self.safe_current()
                    self._w_current(0.0)
                    dev.send_heartbeat_now()
            else:
                self.safe_current()
        finally:
            if self.recorder is not None and not self.recorder.closed:
                if self.final_comments is not None:
                    self.recorder.set_final_comments(self.final_comments())
                self.recorder.close()
            if dev is not None:
                dev.close()
            if self.network is not None:
                try:
                    self.network.disconnect()
                except Exception as exc:  # the bus may already be gone (hub ended)
                    log.warning("disconnect: %s", exc)
            self.rig_counters()
            log.info(
                "node %d stopped (%s): %d cycles, %d late, %d lockstep timeouts, %d input timeouts, "
                "%d module restarts, %d EMCY, peer %s, bus %s",
                self.node_id,
                reason,
                self.stats.cycles,
                self.stats.late_cycles,
                self.stats.lockstep_timeouts,
                self.stats.input_timeouts,
                self.stats.module_restarts,
                self.stats.emcy_raised,
                self.peer.counters,
                self.bus.stats if self.bus else None,
            )

    def rig_counters(self) -> RuntimeStats:
        """The rig driver's counters into :attr:`stats` (``--rig io``: reads that waited out the input
        timeout, module restarts; 0 for a rig that keeps none); returns the stats."""
        rig = self.parts.rig
        self.stats.input_timeouts = int(getattr(rig, "timeouts", 0))
        self.stats.module_restarts = int(getattr(rig, "module_restarts", 0))
        return self.stats

    def safe_current(self) -> None:
        """The rig's current to 0 A (a failure is logged, never raised)."""
        try:
            self.parts.rig.apply_current(0.0)
        except Exception:
            log.exception("could not set the rig's current to 0 A")

    # ------------------------------------------------------------------ callbacks
    def _on_peer(self, ev: PeerEvent) -> None:
        """The peer's heartbeat event: what the NMT-master policy (nodes.nmt_policy) decides, carried out."""
        if ev.node_id != self.peer_id:
            return
        act = on_peer_event(
            ev.kind,
            ev.state,
            nmt_master=self.produce_sync,
            stopping=self.stop_event.is_set(),
            paused=self.peer_paused,
        )
        if not act.heartbeat_ok:
            self.peer.on_heartbeat_timeout()
            log.warning("peer %d lost (no heartbeat for %d ms)", ev.node_id, self.net.heartbeat.consumer_ms)
        else:
            self.peer.on_heartbeat()
        if act.start_fallback:
            self.fallback.start()
        if act.boot:
            self.peer_boots += 1
            self.peer_paused = False
        if act.paused is not None:
            self.peer_paused = act.paused
            self.peer_pauses += 1
            log.warning(
                "peer %d reports NMT state %d%s",
                ev.node_id,
                ev.state,
                ": no PDOs owed until it is OPERATIONAL again" if act.paused else "",
            )
        if ev.kind == "back":
            log.warning("peer %d back (NMT state %s)", ev.node_id, ev.state)
        if act.nmt_start:
            self.device.nmt_command(NmtCommand.START, ev.node_id)
            self.stats.nmt_starts_sent += 1

    def _on_rpdo(self, ev) -> None:
        if ev.number == 1 and self._waiting_first_rpdo:
            self._waiting_first_rpdo = False
            if len(self.stats.latencies_s) < MAX_TIMING_SAMPLES:
                self.stats.latencies_s.append(time.monotonic() - self._sync_sent_at)

    def _on_write(self, ev: WriteEvent) -> None:
        """An accepted SDO write (validated before it was stored; device lock held),
        to the part it concerns."""
        if self.settings.book is None:
            return
        for on_write in (
            self.models.on_write,
            self.ident.on_write,
            self.cycle.on_write,
            self.settings.on_write,
        ):
            if on_write(ev):
                return

    def _on_nmt(self, old: NmtState, new: NmtState, command: int | None) -> None:
        log.info("NMT %s -> %s%s", old.name, new.name, f" (command 0x{command:02X})" if command else "")
        act = on_own_nmt(old, new, command)
        if act.left_operational:
            self.nmt_leaves += 1
        if act.cut_current:
            # no control outside OPERATIONAL: the drive holds no current, and the OD says so (0x2002 showed
            # the last cycle's current)
            self.safe_current()
            if self.device is not None and self._w_current is not None:
                self._w_current(0.0)
        if act.power_on and self.device is not None:
            # reset application (before the boot-up goes out): this program's power-on values in the
            # controller and the OD, a fresh controller state and peer link
            self._power_on()
            self.cycle.state = None

    # ------------------------------------------------------------------ SYNC
    def _on_sync_frame_ignored(self, can_id: int, data: bytes, timestamp: float) -> None:
        """A SYNC frame that the device does not process (STOPPED: no SYNC handler runs) is numbered here, so
        that a node stopped for a whole wrap of the counter (240 SYNCs) keeps the producer's numbering. Same
        receive thread as the device's SYNC handling, so exactly one of the two numbers each frame."""
        if len(data) <= 1 and self.device.state not in (NmtState.OPERATIONAL, NmtState.PRE_OPERATIONAL):
            self._sync_numbering.on_sync(data[0] if data else None)

    def _on_sync(self, tick: SyncTick) -> None:
        self.sync_cycle = self._sync_numbering.on_sync(tick.counter)
        if self.models.pending:
            self.models.take()
        if self.settings.pending:
            self.settings.apply()
        if not tick.operational or self.stop_event.is_set():
            return
        try:
            self.cycle.run(tick)
        except Exception:
            self.stats.cycle_errors += 1
            log.exception("cycle %d failed: current set to 0 A", self.stats.cycles)
            self.safe_current()
            raise
