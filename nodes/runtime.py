"""The node runtime shared by the master and the slave: a CANopen device (telethermo.canopen_dev)
on a python-can bus, a rig, the control core, the peer link and the recording.

On each SYNC (the device's SYNC handler, which runs before the synchronous TPDOs are built):

1. a simulated rig advances by one period (the previous cycle's current held), then is read;
2. the peer values are the RPDO1 committed at this SYNC (the peer's TPDO1 of the previous cycle,
   REAL32), or, in cycle 0, ``initial_peer`` as in the offline runner;
3. the control core steps; the current goes to the rig; estimate and flux go into the OD so that
   TPDO1 carries them at this very SYNC; new trips raise EMCYs, the recording gets a row.

Peer loss (heartbeat timeout, or more than ``peer_pdo_miss_limit`` cycles without its PDO) makes the
core's peer values ``alive=False``: the envelope ramps to neutral and cuts, EMCY 0x8130. When the peer
is back (fresh PDOs, heartbeat seen) and only peer trips are latched, the node clears them
(``clear_faults``): the core resumes bumplessly. Other trips stay latched for the operator.

The SYNC producer (master by default) also runs the schedule: lockstep (SYNC k+1 only after the
peer's PDO of cycle k, or after a timeout when the peer is silent) or real time (wall clock, late
cycles counted in 0x2703 and the log). It is the NMT master of the pair: it starts every node that
reports a boot-up or a pre-operational heartbeat.
"""
from __future__ import annotations

import dataclasses
import logging
import math
import threading
import time
from dataclasses import dataclass, field

import canopen
import numpy as np

from telethermo.canopen_dev.device import Device, NmtCommand, NmtState, PeerEvent, SyncTick, WriteEvent
from telethermo.canopen_dev.netconfig import NetworkConfig
from telethermo.canopen_dev.sync import SyncProducer
from telethermo.control import safety as sf
from telethermo.control.core import CoreState, Feedback, clear_faults, init_state, initial_peer, replace_model, step
from telethermo.control.estimators import Estimator

from telethermo.control.types import Mode, Role
from telethermo.session.runner import _side_row, _truth_row  # the offline runner's row format, exactly
from telethermo.transport.bus import TransportSettings, open_bus

from nodes.odparams import ABORT_DEVICE_STATE, PARAM_KEYS, ParamBook, od_image
from nodes.parts import NodeParts
from nodes.peer import PeerLink
from nodes.recorder import CsvRecorder
from nodes.schedule import LateCycleLog, RealtimeTicker, SyncNumbering

log = logging.getLogger("telethermo.node")

_MODEL_INDICES = frozenset(range(0x2300, 0x2309)) | frozenset(range(0x230A, 0x2310)) | {0x2310, 0x2311}
"""Objects of the TEM model (telethermo.ident.odmodel) and its command: 0x2309 R_sensor is a controller parameter."""

MODE_INDEX = 0x2500
ABORT_MODEL_REFUSED = 0x08000020   # data cannot be transferred or stored to the application
ABORT_NO_DATA = 0x08000024         # no data available
IDENT_NOT_RUN, IDENT_RUNNING, IDENT_DONE, IDENT_INTERRUPTED = 0, 1, 2, 3
PEER_MISS_INDEX = 0x2408
MAX_TIMING_SAMPLES = 1_000_000


def material_status(w, m) -> None:
    """The slave's identified material (telethermo.control.material_stream.MaterialEstimate) into 0x2610..0x2614."""
    ok = math.isfinite(m.effusivity)
    w["identified_material"](m.code)
    w["identified_beta"](m.beta if ok else 0.0)
    w["identified_se_ln_b"](m.se_ln_b if ok else 0.0)
    w["identified_posterior"](m.posterior)
    w["identified_touches"](m.touch & 0xFFFF)


@dataclass
class RuntimeStats:
    """What a node counted (printed at exit, partly in the OD)."""

    cycles: int = 0
    late_cycles: int = 0
    lockstep_timeouts: int = 0
    emcy_raised: int = 0
    peer_resumes: int = 0
    nmt_starts_sent: int = 0
    cycle_errors: int = 0
    fallback_cycles: int = 0
    latencies_s: list[float] = field(default_factory=list)
    """SYNC producer: SYNC sent -> first peer TPDO1 received, s (one per cycle with a PDO)."""
    cycle_s: list[float] = field(default_factory=list)
    """Wall time of this node's own control cycle (SYNC handler), s."""


class NodeRuntime:
    """One node process's machinery. ``start()``, then ``run_producer(...)`` or ``wait()``, then ``stop()``."""

    def __init__(self, role: Role, node_id: int, net: NetworkConfig, transport: TransportSettings,
                 parts: NodeParts, *, mode: Mode, lockstep: bool, produce_sync: bool,
                 recorder: CsvRecorder | None = None, record_timing: bool = True) -> None:
        self.role = role
        self.prefix = "m" if role is Role.MASTER else "s"
        self.node_id = node_id
        self.net = net
        self.transport = transport
        self.parts = parts
        self.mode = self.configured_mode = mode
        self.params = None  # built at start() from the parameter book (defaults + SDO writes)
        self.book: ParamBook | None = None
        self._book_version = 0
        self._script_rs = parts.render_script.first if parts.render_script is not None else None
        self._render_table: dict[str, float] | None = None
        self.lockstep = lockstep
        self.produce_sync = produce_sync
        self.recorder = recorder
        self.record_timing = record_timing
        self._waiting_first_rpdo = False
        self.peer_id = net.peer(role.value).node_id
        self.stats = RuntimeStats()
        self.stop_event = threading.Event()
        self._state: CoreState | None = None
        self._advance_pending = False
        self._last_sync_wall: float | None = None
        self._last_sync_at = 0.0
        self._fallback: threading.Thread | None = None
        self._safety_state = None
        self._material_touch = 0
        self._latched_reported = False
        self._sync_sent_at = 0.0
        self.sync_cycle = -1
        """The SYNC cycle being run: SYNCs numbered from 0 by unwrapping the SYNC counter (both nodes alike)."""
        self._sync_numbering = SyncNumbering(None)
        self.network: canopen.Network | None = None
        self.device: Device | None = None
        self.sync: SyncProducer | None = None
        self.peer = PeerLink()
        self.ticker: RealtimeTicker | None = None
        self.final_comments = None
        self.peer_boots = 0
        self.peer_pauses = 0
        """Changes of the peer between OPERATIONAL and STOPPED/PRE-OPERATIONAL reported by its heartbeat."""
        self._peer_paused = False   # the peer's heartbeat went from OPERATIONAL to STOPPED/PRE-OPERATIONAL
        self._nmt_leaves = 0        # how often this node left OPERATIONAL (its device drops PDOs outside it)
        """Optional () -> comment lines that replace the recording's header at close (final meta)."""
        self.model = parts.model
        """The TEM model the controller runs (the --model file at power-on; 0x230D loads another)."""
        self._model_candidate = None   # (TemModel | None, crc) validated by the last model_command write
        self._model_edited = False     # model objects written since the last model_command
        self._model_pending = None     # the same, to take at the next SYNC
        self._ident_state = IDENT_NOT_RUN
        self._last_T_C = float("nan")
        self._last_sample = None
        self._last_peer = None
        self._fault_reset_pending = False
        self._ident_rec = None   # float32 (T_sensor_C, current_A, Q_W) per sample of the last experiment
        self.models_loaded = 0

    # ------------------------------------------------------------------ life cycle
    def start(self) -> None:
        """Open the bus, power the device on (boot-up, heartbeat), install the handlers."""
        bus = open_bus(self.transport)
        self.network = canopen.Network(bus)
        self.network.connect()
        settings = dataclasses.replace(self.net.device_settings(self.role.value), sync_producer=self.produce_sync)
        eds = self.net.node(self.role.value).eds
        dev = Device(self.network, self.node_id, eds, settings=settings)
        self.device = dev
        dev.add_sync_handler(self._on_sync)
        self._sync_numbering = SyncNumbering(int(dev.read(0x1019)) if 0x1019 in dev.od else 0)
        if not self.produce_sync:   # SYNCs the device ignores (STOPPED) still count (recordings' sync_cycle)
            self.network.subscribe(dev.sync_cob_id, self._on_sync_frame_ignored)
        if self.produce_sync and self.record_timing:
            dev.add_rpdo_listener(self._on_rpdo)
        dev.add_peer_listener(self._on_peer)
        dev.add_write_listener(self._on_write)
        dev.add_nmt_listener(self._on_nmt)
        self._od_writers()
        for key in PARAM_KEYS:
            dev.add_write_validator(key, lambda value, key=key: self.book.check(key, value))
        dev.add_write_validator("model_command", self._check_model_command)
        dev.add_write_validator("fault_reset", self._check_fault_reset)
        dev.add_write_validator("ident_fetch_sample", self._check_ident_fetch)
        self._power_on_parameters()
        if self.produce_sync:
            self.sync = SyncProducer(dev)
        dev.start()
        log.info("node %d (%s) on %s: pre-operational, heartbeat every %d ms, peer %d watched for %d ms",
                 self.node_id, self.role.value, self.transport.describe(), self.net.heartbeat.producer_ms,
                 self.peer_id, self.net.heartbeat.consumer_ms)

    def _od_writers(self) -> None:
        d = self.device
        self._w = {name: d.writer(name) for name in (
            "T_sensor_C", "Q_W", "current_A", "T_sink_C", "contact", "contact_decision", "force_N", "estimate_C", "T_pred_C",
            "T_cmd_C", "safety_state", "last_trip_code", "cycle_counter", "late_cycles", "ident_sample", "ident_state",
            "ident_guard", "ident_start_cycle", "model_status", "model_crc32", "model_command", "fault_reset", "active_trips", "fault_reset_blocked_by",
            "ident_fetched_T_sensor_C", "ident_fetched_current_A", "ident_fetched_Q_W", "identified_material",
            "identified_beta", "identified_se_ln_b", "identified_posterior", "identified_touches")}
        self._ident_fetch_index = d.info.get("ident_fetch_sample").index
        self._fault_reset_index = d.info.get("fault_reset").index
        self._r_peer_est = d.reader("peer_estimate_C")
        self._r_peer_q = d.reader("peer_Q_W")
        self._r_peer_contact = d.reader("peer_contact")
        self._param_w = {key: d.writer(key) for key in PARAM_KEYS}
        self._param_keys = {d.info.get(key).index: key for key in PARAM_KEYS}  # index -> name

    # ------------------------------------------------------------------ parameters in the OD
    def _power_on_parameters(self) -> None:
        """This program's power-on configuration (its --mode, the controller defaults of
        ``default_params`` read now) into the controller and the OD; on start and after a reset node
        (the device has restored the EDS values: a fresh book, a fresh peer link)."""
        from telethermo.control.rendering import load_render_table
        d = self.device
        if self._render_table is None:
            self._render_table = load_render_table()
        script = self.parts.render_script
        self.book = ParamBook(self.role, self.parts.params_for, has_model=self.parts.model is not None,
                              table=self._render_table,
                              od_material=(int(d.read("material_code")), float(d.read("material_beta")),
                                           float(d.read("object_T0_C"))),
                              script_first=self._script_rs if script is not None else None,
                              mode=self.configured_mode, peer_miss_limit=int(d.read(PEER_MISS_INDEX)))
        self.mode = self.configured_mode
        self.params = self.book.params(render=self._scripted_render())
        self._book_version = self.book.version
        self.peer = PeerLink(max_missed_cycles=self.book.peer_miss_limit)
        d.write(0x2704, bool(self.lockstep), check=False)
        self.model = self.parts.model
        self.book.has_model = self.model is not None
        self._model_candidate = self._model_pending = None
        self._ident_state = IDENT_NOT_RUN
        self._write_model_objects(self.model)
        self._write_parameter_image()

    # ------------------------------------------------------------------ the model in the OD
    def _write_model_objects(self, tem) -> None:
        """The running model into 0x2300..0x2311, its status and CRC (none: status 0, CRC 0)."""
        from telethermo.ident import odmodel
        if tem is None:
            self._w["model_status"](odmodel.STATUS_NONE)
            self._w["model_crc32"](0)
            return
        try:
            entries = odmodel.model_entries(tem)
        except ValueError as exc:   # ModelFileError: more parameters than the objects hold
            log.warning("the model runs but cannot be shown in the OD: %s", exc)
            self._w["model_status"](odmodel.STATUS_LOADED)
            self._w["model_crc32"](0)
            return
        for e in entries:
            self.device.write((e.index, e.sub), e.value, check=False)
        self._w["model_status"](odmodel.STATUS_LOADED)
        self._w["model_crc32"](odmodel.od_crc32(entries))

    def _check_model_command(self, value) -> int | None:
        """Validator of model_command (0x230D), device lock held: 1 loads the model the objects hold (refused
        with 0x08000020 if inconsistent, at another period or unstable), 2 unloads (refused with 0x08000022
        while the controller needs a model)."""
        from telethermo.ident import odmodel
        from telethermo.ident.modelfile import ModelFileError
        value = int(value)
        p = self.book.params() if self.book is not None else None   # what is requested, not only what runs
        uses_model = p is not None and (p.estimator is not Estimator.FLUX or p.feedback is Feedback.MODEL)
        if value == odmodel.CMD_LOAD:
            if uses_model and self.book.mode in (Mode.TELEPRESENCE, Mode.RENDER):
                # a new predictor starts at rest: under a model-driven controller its transient would reach
                # the pad (and the peer); swap it while the flux estimator drives, or in idle
                log.warning("model_command 1 refused: the %s estimator drives the pad in %s", p.estimator.value,
                            self.book.mode.name)
                return ABORT_DEVICE_STATE
            d = self.device
            try:
                tem, entries = odmodel.model_from_od(lambda i, s: d.read((i, s)), source=f"node {self.node_id} OD",
                                                     period_s=self.parts.period_s)
            except ModelFileError as exc:
                log.warning("model_command 1 refused: %s", exc)
                return ABORT_MODEL_REFUSED
            self._model_candidate = (tem, odmodel.od_crc32(entries))
        elif value == odmodel.CMD_UNLOAD:
            if uses_model:
                log.warning("model_command 2 refused: the estimator %s needs the model", p.estimator.value)
                return ABORT_DEVICE_STATE
            self._model_candidate = (None, 0)
        else:
            self._model_candidate = None
        return None

    def _take_model(self) -> None:
        """At a SYNC (lock held): run the model loaded by 0x230D from now on."""
        from telethermo.ident import odmodel
        tem, crc = self._model_pending
        self._model_pending = None
        self.model = tem
        self.book.has_model = tem is not None
        if self._state is not None:
            T0 = self._last_T_C if self._last_T_C == self._last_T_C else self.params.safety.neutral_C
            self._state = replace_model(self._state, tem, T0)
        status = odmodel.STATUS_LOADED if tem is not None else odmodel.STATUS_NONE
        if tem is not None and self._model_edited:
            status = odmodel.STATUS_EDITED   # objects written after the load command: they differ from what runs
        self._w["model_status"](status)
        self._w["model_crc32"](crc)
        self._w["model_command"](0)
        self.models_loaded += 1
        if tem is None:
            log.info("model unloaded")
        else:
            o = tem.temperature.orders
            log.info("model loaded from the OD: orders %d,%d,%d,%d, T_ref %.3f °C, CRC 0x%08X", o.n, o.m, o.p, o.q,
                     tem.temperature.T_ref_C, crc)

    def _scripted_render(self):
        """The render script's settings in force (with the operator's pad β / finger temperature),
        or None when the OD's settings are rendered (no script, or the operator chose a material)."""
        if self.parts.render_script is None or not self.book.scripted:
            return None
        return self.book.overlay(self._script_rs)

    def _render_view(self):
        """The render settings the OD shows: rendered now (RENDER) or to be rendered."""
        if self.mode is Mode.RENDER:
            return self.params.render
        rs = self._scripted_render()
        return rs if rs is not None else self.book.render_settings()

    def _write_parameter_image(self) -> None:
        rs = self._render_view()
        img = od_image(self.params, rs, material_code=self.book.material_code(rs),
                       peer_miss_limit=self.book.peer_miss_limit)
        w = self._param_w
        for key, value in img.items():
            w[key](value)

    def _apply_parameters(self) -> None:
        """Take the SDO writes accepted since the last SYNC (called at the start of a SYNC)."""
        book = self.book
        self._book_version = book.version
        old_mode = self.mode
        try:
            params = book.params(render=self._scripted_render())
        except ValueError as exc:  # the validators refuse what cannot be built: not expected
            log.error("parameters refused at SYNC (%s); keeping the running ones", exc)
            self._write_parameter_image()
            return
        self.mode, self.params = book.mode, params
        self.peer.max_missed_cycles = book.peer_miss_limit
        if self.mode is not old_mode:
            log.info("mode %s -> %s", old_mode.name, self.mode.name)
        self._write_parameter_image()

    def stop(self, reason: str = "stop") -> None:
        """Current to zero, last heartbeat, recording closed, bus released. Idempotent."""
        self.stop_event.set()
        dev = self.device
        try:
            if dev is not None:
                with dev.lock:  # no SYNC handler runs while we cut the current
                    self._safe_current()
                    self._w["current_A"](0.0)
                    dev.send_heartbeat_now()
            else:
                self._safe_current()
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
            log.info("node %d stopped (%s): %d cycles, %d late, %d lockstep timeouts, %d EMCY, peer %s",
                     self.node_id, reason, self.stats.cycles, self.stats.late_cycles, self.stats.lockstep_timeouts,
                     self.stats.emcy_raised, self.peer.counters)

    def _safe_current(self) -> None:
        try:
            self.parts.rig.apply_current(0.0)
        except Exception:
            log.exception("could not set the rig's current to 0 A")

    # ------------------------------------------------------------------ callbacks
    def _on_peer(self, ev: PeerEvent) -> None:
        if ev.node_id != self.peer_id:
            return
        if ev.kind == "lost":
            self.peer.on_heartbeat_timeout()
            log.warning("peer %d lost (no heartbeat for %d ms)", ev.node_id, self.net.heartbeat.consumer_ms)
            if not self.produce_sync:
                self._start_fallback()
        else:
            self.peer.on_heartbeat()
            if ev.kind == "bootup":
                self.peer_boots += 1
                self._peer_paused = False
            if ev.kind == "state":
                # another NMT master stopped the peer or put it into PRE-OPERATIONAL (or started it again):
                # a peer that left OPERATIONAL answers no SYNC, so it owes no PDO (lockstep). Only a change
                # from OPERATIONAL counts: before its first start a peer owes its PDOs from the start on.
                paused = ev.state != int(NmtState.OPERATIONAL)
                if paused != self._peer_paused and (paused or self._peer_paused):
                    self._peer_paused = paused
                    self.peer_pauses += 1
                    log.warning("peer %d reports NMT state %d%s", ev.node_id, ev.state,
                                ": no PDOs owed until it is OPERATIONAL again" if paused else "")
            if ev.kind == "back":
                log.warning("peer %d back (NMT state %s)", ev.node_id, ev.state)
        # the NMT master starts a peer that (re)booted or reports pre-operational: once per boot-up (a
        # boot-up after a loss also comes as "back" with state 0), once per pre-operational report
        # (first heartbeat, return, or a change of state, e.g. another NMT master's command)
        if (self.produce_sync and not self.stop_event.is_set()
                and (ev.kind == "bootup" or (ev.kind != "lost" and ev.state == int(NmtState.PRE_OPERATIONAL)))):
            self.device.nmt_command(NmtCommand.START, ev.node_id)
            self.stats.nmt_starts_sent += 1

    # ------------------------------------------------------------------ SYNC consumer without SYNC
    def _start_fallback(self) -> None:
        """The SYNC producer is gone: run our cycles on a local timer (peer lost: the envelope ramps
        to neutral, then cuts) until SYNC or the peer's heartbeat come back."""
        if (self._fallback is not None and self._fallback.is_alive()) or self.device.state is not NmtState.OPERATIONAL:
            return
        self._fallback = threading.Thread(target=self._fallback_loop, name="sync-fallback", daemon=True)
        self._fallback.start()

    def _fallback_loop(self) -> None:
        dev = self.device
        period = self.parts.period_s
        ticker = RealtimeTicker(period)
        log.warning("no SYNC producer: local fallback cycles every %g ms", period * 1e3)
        n = 0
        while not self.stop_event.is_set() and dev.peer_status(self.peer_id) == "lost":
            ticker.wait_next()
            if time.monotonic() - self._last_sync_at < 2 * period:
                continue  # SYNC still arrives (only the heartbeat is missing)
            with dev.lock:
                if self.stop_event.is_set() or dev.state is not NmtState.OPERATIONAL or self._state is None:
                    continue
                try:
                    self._cycle(SyncTick(None, (), True), fallback=True)
                    n += 1
                except Exception:
                    self.stats.cycle_errors += 1
                    log.exception("fallback cycle failed: current set to 0 A")
                    self._safe_current()
        self.stats.fallback_cycles += n
        log.warning("local fallback cycles ended after %d cycles", n)

    def _on_rpdo(self, ev) -> None:
        if ev.number == 1 and self._waiting_first_rpdo:
            self._waiting_first_rpdo = False
            if len(self.stats.latencies_s) < MAX_TIMING_SAMPLES:
                self.stats.latencies_s.append(time.monotonic() - self._sync_sent_at)

    def _on_write(self, ev: WriteEvent) -> None:
        """An accepted SDO write of a parameter (validated before it was stored; device lock held):
        into the book now, into the controller at the next SYNC."""
        if self.book is None:
            return
        if ev.index in _MODEL_INDICES:
            self._on_model_write(ev)
            return
        if ev.index == self._ident_fetch_index:
            T, I, Q = (float(v) for v in self._ident_rec[int(ev.value)])
            w = self._w
            w["ident_fetched_T_sensor_C"](T)
            w["ident_fetched_current_A"](I)
            w["ident_fetched_Q_W"](Q)
            return
        if ev.index == self._fault_reset_index:
            self._fault_reset_pending = int(ev.value) == 1
            self._w["fault_reset"](0)   # a command: reads 0
            return
        key = self._param_keys.get(ev.index)
        if key is None:
            return
        try:
            self.book.apply(key, ev.value)
        except ValueError as exc:
            log.error("%s = %r not applied: %s", key, ev.value, exc)
            self.book.version += 1  # the next SYNC rewrites the OD with the truth
        log.info("%s = %r (takes effect at the next SYNC)", key, ev.value)

    def _check_ident_fetch(self, value) -> int | None:
        """Validator of ident_fetch_sample (0x280B): a sample the last experiment recorded, else 0x08000024."""
        rec = self._ident_rec
        j = int(value)
        if rec is None or j >= len(rec) or rec[j, 0] != rec[j, 0]:
            return ABORT_NO_DATA
        return None

    def _check_fault_reset(self, value) -> int | None:
        """Validator of fault_reset (0x240A), device lock held: refuse (0x08000022) while a latched trip's
        cause persists in the last sample, so that the operator learns it at once; nothing is cleared then."""
        st = self._state
        if int(value) != 1 or st is None or not st.env.trips or self._last_sample is None:
            return None
        after = clear_faults(self._last_sample, self._last_peer, self.params, st)
        if after.env.trips:
            log.warning("fault reset refused: %s persist", ", ".join(sorted(t.value for t in after.env.trips)))
            self._w["fault_reset_blocked_by"](sf.trips_mask(after.env.trips))   # the client reads why
            return ABORT_DEVICE_STATE
        return None

    def _on_model_write(self, ev: WriteEvent) -> None:
        from telethermo.ident import odmodel
        if ev.index == odmodel.COMMAND_INDEX:
            self._model_pending, self._model_candidate = self._model_candidate, None
            self._model_edited = False
            if self._model_pending is not None and self._model_pending[0] is None:
                self.book.has_model = False   # unloading: from now on no write may select the model estimator
            self._w["model_command"](0)   # a command, not a setting: reads 0
        else:
            self._model_edited = True
            if self.model is not None:
                self._w["model_status"](odmodel.STATUS_EDITED)

    def _on_nmt(self, old: NmtState, new: NmtState, command: int | None) -> None:
        log.info("NMT %s -> %s%s", old.name, new.name, f" (command 0x{command:02X})" if command else "")
        if new is not NmtState.OPERATIONAL and old is NmtState.OPERATIONAL:
            self._nmt_leaves += 1
        if new is not NmtState.OPERATIONAL:
            # no control outside OPERATIONAL: the drive holds no current, and the OD says so (0x2002 showed
            # the last cycle's current)
            self._safe_current()
            if self.device is not None and getattr(self, "_w", None):
                self._w["current_A"](0.0)
        if command == NmtCommand.RESET_NODE and self.device is not None and new is NmtState.INITIALISING:
            # reset application (before the boot-up goes out): this program's power-on values in the
            # controller and the OD, a fresh controller state and peer link
            self._power_on_parameters()
            self._state = None

    # ------------------------------------------------------------------ the cycle
    def _on_sync_frame_ignored(self, can_id: int, data: bytes, timestamp: float) -> None:
        """A SYNC frame that the device does not process (STOPPED: no SYNC handler runs) is numbered here, so
        that a node stopped for a whole wrap of the counter (240 SYNCs) keeps the producer's numbering. Same
        receive thread as the device's SYNC handling, so exactly one of the two numbers each frame."""
        if len(data) <= 1 and self.device.state not in (NmtState.OPERATIONAL, NmtState.PRE_OPERATIONAL):
            self._sync_numbering.on_sync(data[0] if data else None)

    def _on_sync(self, tick: SyncTick) -> None:
        self.sync_cycle = self._sync_numbering.on_sync(tick.counter)
        if self._model_pending is not None:
            self._take_model()
        if self.book.version != self._book_version:
            self._apply_parameters()
        if not tick.operational or self.stop_event.is_set():
            return
        try:
            self._cycle(tick)
        except Exception:
            self.stats.cycle_errors += 1
            log.exception("cycle %d failed: current set to 0 A", self.stats.cycles)
            self._safe_current()
            raise

    def _cycle(self, tick: SyncTick, *, fallback: bool = False) -> None:
        now = time.monotonic()
        if fallback and self.book.version != self._book_version:
            self._apply_parameters()
        if not fallback:
            self._last_sync_at = now
        if not self.produce_sync and not self.lockstep:
            last = self._last_sync_wall
            if last is not None and now - last > 1.5 * self.parts.period_s:
                self.stats.late_cycles += 1
            self._last_sync_wall = now
        rig = self.parts.rig
        if self._advance_pending:
            rig.advance(self.parts.period_s)
        sample = rig.read()
        if self._state is None:
            self._state = init_state(self.params, self.model, sample)
            self.peer.start_with(initial_peer(sample))  # cycle 0 as the offline runner; then PDOs
        if 1 in tick.fresh_rpdos:
            self.peer.on_pdo(self._r_peer_est(), self._r_peer_q())
        if 2 in tick.fresh_rpdos:
            self.peer.on_contact(bool(self._r_peer_contact()))
        peer = self.peer.take()
        if self.mode is Mode.RENDER:
            peer = None  # rendering needs no peer (as offline)
            self._select_render_touch(sample.t_s)
        state = self._state
        if self._fault_reset_pending:
            self._fault_reset_pending = False
            state = self._operator_fault_reset(sample, peer, state)
        if peer is not None and peer.alive and peer.fresh and state.env.trips \
                and state.env.trips <= sf.PEER_TRIPS:
            state = clear_faults(sample, peer, self.params, state)
            cleared = set(self._state.env.trips) - set(state.env.trips)
            for trip in cleared:
                self.device.clear_emcy(sf.EMCY_CODES[trip])
            if cleared:
                self.stats.peer_resumes += 1
                log.warning("peer values back: cleared %s, resuming", ", ".join(t.value for t in cleared))
        elif peer is not None and peer.alive and peer.fresh and state.env.trips & sf.PEER_TRIPS:
            if not self._latched_reported:   # once per episode: say why we stay cut after the peer's return
                self._latched_reported = True
                log.warning("peer values back, but %s latched: the envelope stays as it is until an operator "
                            "reset (telethermo fault-reset, or NMT reset node)",
                            ", ".join(sorted(t.value for t in state.env.trips - sf.PEER_TRIPS)))
        if self._latched_reported and not (state.env.trips & sf.PEER_TRIPS):
            self._latched_reported = False
        res = step(sample, peer, self.params, state)
        self._state = res.state
        rig.apply_current(res.current_A)
        self._advance_pending = self.parts.simulated
        st = res.status
        w = self._w
        w["estimate_C"](res.out.estimate_C)
        w["Q_W"](res.out.flux_W)
        w["T_sensor_C"](sample.T_sensor_C)
        w["current_A"](res.current_A)
        w["T_sink_C"](sample.T_sink_C)
        w["contact"](bool(sample.contact))
        w["contact_decision"](bool(res.out.contact))
        w["force_N"](sample.force_N)
        w["T_pred_C"](st.T_pred_C)
        w["T_cmd_C"](st.setpoint_C)
        w["safety_state"](int(st.safety.state))
        w["active_trips"](sf.trips_mask(res.state.env.trips))
        if st.safety.state != self._safety_state:
            if self._safety_state is not None:
                log.info("cycle %d: safety state %s -> %s", self.stats.cycles, self._safety_state.name,
                         st.safety.state.name)
            self._safety_state = st.safety.state
        self._identify_status(res.state, sample, res)
        if st.material is not None and st.material.touch != self._material_touch:
            material_status(w, st.material)
            self._material_touch = st.material.touch
        self._last_T_C = sample.T_sensor_C
        self._last_sample, self._last_peer = sample, peer
        self.stats.cycles += 1
        w["cycle_counter"](self.stats.cycles & 0xFFFFFFFF)
        w["late_cycles"](self.stats.late_cycles & 0xFFFFFFFF)
        for trip in st.safety.new_trips:
            code = sf.EMCY_CODES[trip]
            w["last_trip_code"](code)
            self.device.raise_emcy(code)
            self.stats.emcy_raised += 1
            log.warning("cycle %d: trip %s (EMCY 0x%04X)", self.stats.cycles - 1, trip.value, code)
        if self.recorder is not None:
            self._record(sample, res, peer, -1 if fallback else self.sync_cycle)
        if self.record_timing and len(self.stats.cycle_s) < MAX_TIMING_SAMPLES:
            self.stats.cycle_s.append(time.monotonic() - now)

    def _operator_fault_reset(self, sample, peer, state: CoreState) -> CoreState:
        """The operator's fault reset (0x240A = 1) at this SYNC: the trips whose cause is gone are cleared
        (their EMCYs too), the envelope restarts bumplessly from the surface."""
        if not state.env.trips:
            log.info("fault reset: nothing latched")
            return state
        new = clear_faults(sample, peer, self.params, state)
        gone = set(state.env.trips) - set(new.env.trips)
        for trip in gone:
            self.device.clear_emcy(sf.EMCY_CODES[trip])
        log.warning("operator fault reset: cleared %s%s", ", ".join(sorted(t.value for t in gone)) or "nothing",
                    f"; still latched: {', '.join(sorted(t.value for t in new.env.trips))}" if new.env.trips else "")
        self._latched_reported = False
        return new

    def _identify_status(self, state: CoreState, sample, res) -> None:
        """ident_sample / ident_state / ident_guard / ident_start_cycle of this cycle (0x2807..0x280A), and the
        sample kept for ident_fetch_sample (0x280B): the values its TPDOs carry, as REAL32."""
        w, k = self._w, state.ident_k
        w["ident_sample"](k)
        if self.mode is Mode.IDENTIFY:
            total = self.params.identify.total
            if k == 1:
                self._ident_rec = np.full((total, 3), np.nan, dtype=np.float32)
            if 1 <= k <= total and self._ident_rec is not None and len(self._ident_rec) == total:
                self._ident_rec[k - 1] = (sample.T_sensor_C, res.current_A, res.out.flux_W)
            if k == 1:
                w["ident_start_cycle"](self.stats.cycles & 0xFFFFFFFF)
                log.info("identification experiment started: %d samples (%s)", self.params.identify.total,
                         self.params.identify.as_dict())
            new = IDENT_DONE if k >= self.params.identify.total else IDENT_RUNNING
            if new == IDENT_DONE and self._ident_state == IDENT_RUNNING:
                log.info("identification experiment done: %d samples, %d guarded", k, state.ident_guard)
            w["ident_guard"](state.ident_guard)
        else:
            new = IDENT_INTERRUPTED if self._ident_state == IDENT_RUNNING else self._ident_state
            if new == IDENT_INTERRUPTED and self._ident_state == IDENT_RUNNING:
                log.warning("identification experiment interrupted (mode %s)", self.mode.name)
        if new != self._ident_state:
            self._ident_state = new
            w["ident_state"](new)

    def _select_render_touch(self, t_s: float) -> None:
        """The render script's settings in force now (the same script as the offline runner's), unless
        the operator chose the material by SDO; the OD shows them."""
        script = self.parts.render_script
        if script is not None and self.book.scripted:
            rs = script.settings_at(t_s, self.parts.period_s, self.parts.finger_skin)
            if rs is not self._script_rs:
                self._script_rs = rs
                rs = self.book.overlay(rs)
                if rs is not self.params.render:
                    self.params = dataclasses.replace(self.params, render=rs)
                    self._write_parameter_image()

    def _record(self, sample, res, peer, sync_cycle: int) -> None:
        row = {"t_s": sample.t_s, "sync_cycle": sync_cycle}
        row.update(_side_row(self.prefix, sample, res, peer))
        if self.parts.truth is not None:
            row.update(_truth_row(self.prefix, self.parts.rig))
        else:   # hardware: no simulator truth, the same columns (NaN), so every reader reads it
            row.update(dict.fromkeys((c for c in self.recorder.columns if c not in row), float("nan")))
        self.recorder.write(row)

    # ------------------------------------------------------------------ SYNC producer
    def wait_for_peer(self, timeout_s: float) -> bool:
        """Wait until the peer's heartbeat is seen (it is started by NMT when it is)."""
        deadline = time.monotonic() + timeout_s
        while not self.stop_event.is_set() and time.monotonic() < deadline:
            if self.device.peer_status(self.peer_id) == "alive":
                return True
            self.stop_event.wait(0.01)
        return False

    def run_producer(self, cycles: int, *, progress_every: int = 0, progress=None) -> int:
        """Start all nodes (NMT) and run ``cycles`` SYNC cycles (0 = until stopped); return cycles run."""
        dev, sync = self.device, self.sync
        assert dev is not None and sync is not None
        dev.nmt_command(NmtCommand.START, 0)
        period = self.parts.period_s
        # how long one lockstep cycle waits for the peer's PDO: half the heartbeat consumer time, so that
        # a merely slow peer is told from a lost one (which the heartbeat consumer reports)
        wait_s = self.net.heartbeat.consumer_ms * 0.5e-3 or 0.5
        patience_s = 20 * wait_s  # a peer alive by its heartbeat but silent this long: count, go on
        ticker = None if self.lockstep else RealtimeTicker(period, tolerance_s=period / 2)
        self.ticker = ticker
        late_log = LateCycleLog(log)   # one summary line per second at most, not one per late cycle
        k = 0
        # lockstep bookkeeping: PDOs owed by the peer (one per SYNC it was sent while believed alive).
        # A PDO that comes after its wait timed out is still owed: the next cycle waits for both, so a
        # slow peer falls back into step instead of staying one PDO behind.
        # the peer's PDOs of one SYNC: TPDO1 (estimate, flux), then TPDO5 (contact flag), in that order on an
        # ordered transport; waiting for the last synchronous RPDO means every one of the cycle is in
        last = max((n for n, p in dev.rpdos.items() if p.valid and p.trans_type <= 240), default=1)
        owed, base = 0, dev.rpdo_count(last)
        boots, pauses, leaves = self.peer_boots, self.peer_pauses, self._nmt_leaves
        while not self.stop_event.is_set() and (cycles == 0 or k < cycles):
            if dev.state is not NmtState.OPERATIONAL:
                # stopped or pre-operational by an NMT command from elsewhere: no control cycles of ours.
                # CiA 301: the SYNC producer produces in PRE-OPERATIONAL too (paced by the period; the
                # SYNC handlers see tick.operational False, no PDO goes out); in STOPPED it does not
                if ticker is not None:
                    ticker.wait_next()
                else:
                    self.stop_event.wait(period)
                if dev.state is NmtState.PRE_OPERATIONAL and not self.stop_event.is_set():
                    sync.transmit()
                continue
            if ticker is not None:
                late, lateness = ticker.wait_next()
                if late:
                    self.stats.late_cycles = ticker.stats.late_cycles
                late_log.cycle(k, late, lateness)
            status = dev.peer_status(self.peer_id)
            if (status != "alive" or boots != self.peer_boots or pauses != self.peer_pauses
                    or leaves != self._nmt_leaves):
                # lost, never seen, rebooted, stopped/pre-operational or started again: owes nothing (the
                # SYNCs it did not answer are never answered); we left OPERATIONAL: its PDOs were dropped
                owed, base, boots, pauses, leaves = (0, dev.rpdo_count(last), self.peer_boots, self.peer_pauses,
                                                     self._nmt_leaves)
            if self._peer_paused:
                status = "paused"
            self._sync_sent_at = time.monotonic()
            self._waiting_first_rpdo = True
            if sync.transmit() is None:  # holds the device lock until our own SYNC k is processed (no early PDO k)
                continue   # stopped by an NMT command that came while we waited for the slot: no SYNC sent
            k += 1
            if self.lockstep:
                if status == "alive":
                    owed += 1
                    # lockstep means SYNC k+1 only after the peer's PDO k: while the heartbeat consumer
                    # still sees the peer alive it is merely slow (a loaded machine), so keep waiting, up
                    # to a patience bound for a peer whose heartbeat runs but whose cycle hangs
                    waited, arrived = 0.0, False
                    while not arrived and waited < patience_s and not self.stop_event.is_set():
                        arrived = dev.wait_rpdo(last, after=base + owed - 1, timeout=wait_s)
                        waited += wait_s
                        if not arrived and (dev.peer_status(self.peer_id) != "alive" or self._peer_paused
                                            or leaves != self._nmt_leaves):
                            break
                    if arrived:
                        base, owed = dev.rpdo_count(last), 0
                    elif leaves != self._nmt_leaves:
                        pass   # we were stopped meanwhile: the debt is dropped at the next cycle
                    else:
                        self.stats.lockstep_timeouts += 1
                        log.warning("cycle %d: no PDO of node %d within %g ms (%d owed)", k - 1, self.peer_id,
                                    waited * 1e3, owed)
                elif status == "unknown" and self.mode is not Mode.TELEPRESENCE:
                    pass  # alone on the bus (rendering, identification): nobody to wait for
                else:
                    # peer lost, not yet seen or not OPERATIONAL: our envelope keeps running, paced by the SYNC period
                    dev.wait_rpdo(last, after=dev.rpdo_count(last), timeout=period)
            if progress is not None and progress_every and (k % progress_every == 0 or k == cycles):
                progress(k, cycles)
        late_log.flush()
        # the session is over: every node leaves OPERATIONAL (no PDOs, current 0) before we go silent,
        # so that the peer does not take our end for a loss
        if dev.state is NmtState.OPERATIONAL:
            dev.nmt_command(NmtCommand.ENTER_PRE_OPERATIONAL, 0)
        return k
