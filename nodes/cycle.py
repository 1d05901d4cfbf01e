"""The control cycle of a node, run on each SYNC (the device's SYNC handler, which runs before the
synchronous TPDOs are built), or by the local fallback timer when the SYNC producer is gone:

1. a simulated rig advances by one period (the previous cycle's current held), then is read;
2. the peer values are the RPDO1 committed at this SYNC (the peer's TPDO1 of the previous cycle,
   REAL32), or, in cycle 0, ``initial_peer`` as in the offline runner;
3. the peer policy (telethermo.control.peer_policy) decides whether a node tripped by the peer's loss
   resumes: the peer is back and only peer trips are latched;
4. the control core steps; the current goes to the rig; estimate and flux go into the OD so that
   TPDO1 carries them at this very SYNC; new trips raise EMCYs, the recording gets a row.

The operator's fault reset (0x240A = 1) is validated at once (refused while a latched trip's cause
persists) and carried out at the next cycle.
"""

from __future__ import annotations

import logging
import math
import time
from typing import Any, Callable

from telethermo.cia301 import ABORT_DEVICE_STATE, EMCY_LINK_FALLBACK
from telethermo.device.device import SyncTick
from telethermo.control import safety as sf
from telethermo.control.core import (
    CoreState,
    StepResult,
    clear_faults,
    init_state,
    initial_peer,
    replace_model,
    step,
)
from telethermo.control.peer_policy import PeerResume, peer_resume, resume
from telethermo.control.types import Mode, PeerValues
from telethermo.rig import RigSample
from telethermo.recording.rows import side_row, truth_row

from telethermo.nodes.od_publish import (
    CYCLE_COUNTER,
    FAULT_RESET,
    FAULT_RESET_BLOCKED_BY,
    LAST_TRIP_CODE,
    INPUT_TIMEOUTS,
    LATE_CYCLES,
    MODULE_RESTARTS,
    NODE_OBJECTS,
    OdRow,
    Publisher,
)
from telethermo.nodes.ports import CycleHost

log = logging.getLogger("telethermo.node")

MAX_TIMING_SAMPLES = 1_000_000


class ControlCycle:
    """The controller's state between cycles (``state``, None until the first cycle) and one cycle's work."""

    def __init__(self, rt: CycleHost) -> None:
        self.rt = rt
        self.state: CoreState | None = None
        self.advance_pending = False
        self.last_sync_at = 0.0
        """Monotonic time of the last SYNC-driven cycle, s (the fallback runs only when SYNCs stop)."""
        self._last_sync_wall: float | None = None
        self._safety_state = None
        self._material_touch: tuple[int, str] = (0, "")
        self._latched_reported = False
        self._last_T_C = float("nan")
        self._last_sample: RigSample | None = None
        self._last_peer: PeerValues | None = None
        self._fault_reset_pending = False
        self._fault_reset_index = -1
        self._link_fallback = False
        self.publish: Publisher | None = None
        self._w: dict[OdRow, Callable[[Any], None]] = {}

    def bind(self, dev) -> None:
        self.publish = Publisher(dev.writer)
        self._w = {row: dev.writer(row.key) for row in NODE_OBJECTS}
        self._fault_reset_index = FAULT_RESET.index
        self._r_peer_est = dev.reader("peer_estimate_C")
        self._r_peer_q = dev.reader("peer_Q_W")
        self._r_peer_contact = dev.reader("peer_contact")
        self._r_peer_material = tuple(
            dev.reader(n)
            for n in (
                "peer_identified_material",
                "peer_identified_beta",
                "peer_identified_touches",
                "peer_identified_T_object0_C",
            )
        )
        dev.add_write_validator("fault_reset", self.check_fault_reset)

    def swap_model(self, tem, neutral_C: float) -> None:
        """A new model from now on: its predictor starts at the last measured T_sensor
        (else ``neutral_C``)."""
        if self.state is not None:
            T0 = self._last_T_C if self._last_T_C == self._last_T_C else neutral_C
            self.state = replace_model(self.state, tem, T0)

    # ------------------------------------------------------------------ one cycle
    def run(self, tick: SyncTick, *, fallback: bool = False) -> None:
        """One control cycle (device lock held)."""
        rt = self.rt
        now = time.monotonic()
        if fallback and rt.settings.pending:
            rt.settings.apply()
        if not fallback:
            self.last_sync_at = now
        if not rt.produce_sync and not rt.lockstep:
            last = self._last_sync_wall
            if last is not None and now - last > 1.5 * rt.parts.period_s:
                rt.stats.late_cycles += 1
            self._last_sync_wall = now
        sample, peer = self._inputs(tick)
        state = self.state
        if self._fault_reset_pending:
            self._fault_reset_pending = False
            state = self._operator_fault_reset(sample, peer, state)
        state = self._peer_policy(sample, peer, state)
        res = step(sample, peer, rt.settings.params, state)
        self.state = res.state
        rt.parts.rig.apply_current(res.current_A)
        self.advance_pending = rt.parts.simulated
        self._publish(sample, res)
        rt.ident.status(res.state, sample, res)
        self._last_T_C = sample.T_sensor_C
        self._last_sample, self._last_peer = sample, peer
        rt.stats.cycles += 1
        self._w[CYCLE_COUNTER](rt.stats.cycles & 0xFFFFFFFF)
        self._w[LATE_CYCLES](rt.stats.late_cycles & 0xFFFFFFFF)
        stats = rt.rig_counters()  # --rig io: the driver's counters (0 for a rig that keeps none)
        self._w[INPUT_TIMEOUTS](stats.input_timeouts & 0xFFFFFFFF)
        self._w[MODULE_RESTARTS](stats.module_restarts & 0xFFFFFFFF)
        self._raise_trips(res)
        if rt.recorder is not None:
            self._record(sample, res, peer, -1 if fallback else rt.sync_cycle)
        if rt.record_timing and len(rt.stats.cycle_s) < MAX_TIMING_SAMPLES:
            rt.stats.cycle_s.append(time.monotonic() - now)

    def _inputs(self, tick: SyncTick) -> tuple[RigSample, PeerValues | None]:
        """The rig's sample (a simulated rig advanced first) and the peer's values of this cycle."""
        rt = self.rt
        rig = rt.parts.rig
        if self.advance_pending:
            rig.advance(rt.parts.period_s)
        sample = rig.read()
        if self.state is None:
            self.state = init_state(rt.settings.params, rt.models.model, sample)
            rt.peer.start_with(initial_peer(sample))  # cycle 0 as the offline runner; then PDOs
        if 1 in tick.fresh_rpdos:
            rt.peer.on_pdo(self._r_peer_est(), self._r_peer_q())
        if 2 in tick.fresh_rpdos:
            rt.peer.on_contact(bool(self._r_peer_contact()))
        # the slave's identification, as its contact PDO (RPDO2) and RPDO3 last brought it
        code, beta, touch, T_o0 = [r() for r in self._r_peer_material]
        peer = rt.peer.take((int(code), float(beta), int(touch), float(T_o0) if code else math.nan))
        if rt.settings.mode is Mode.RENDER:
            peer = None  # rendering needs no peer (as offline)
            rt.settings.select_render_touch(sample.t_s)
        return sample, peer

    def _peer_policy(self, sample: RigSample, peer: PeerValues | None, state: CoreState) -> CoreState:
        """Resume when the peer is back and only peer trips are latched (telethermo.control.peer_policy);
        say once per episode why the node stays cut when other trips are latched."""
        decision = peer_resume(peer, frozenset(state.env.trips))
        if decision is PeerResume.RESUME:
            state, cleared = resume(sample, peer, self.rt.settings.params, state)
            for trip in cleared:
                self.rt.device.clear_emcy(sf.EMCY_CODES[trip])
            if cleared:
                self.rt.stats.peer_resumes += 1
                log.warning("peer values back: cleared %s, resuming", ", ".join(t.value for t in cleared))
        elif decision is PeerResume.LATCHED and not self._latched_reported:
            self._latched_reported = True  # once per episode: why we stay cut after the peer's return
            log.warning(
                "peer values back, but %s latched: the envelope stays as it is until an operator "
                "reset (telethermo fault-reset, or NMT reset node)",
                ", ".join(sorted(t.value for t in state.env.trips - sf.PEER_TRIPS)),
            )
        if self._latched_reported and not (state.env.trips & sf.PEER_TRIPS):
            self._latched_reported = False
        return state

    def _publish(self, sample: RigSample, res: StepResult) -> None:
        """This cycle's values into the OD (TPDO1 carries estimate and flux at this SYNC)."""
        st = res.status
        self.publish.cycle(sample, res)
        if st.safety.state != self._safety_state:
            if self._safety_state is not None:
                log.info(
                    "cycle %d: safety state %s -> %s",
                    self.rt.stats.cycles,
                    self._safety_state.name,
                    st.safety.state.name,
                )
            self._safety_state = st.safety.state
        # a new touch's first answer, and its refined one later in the same touch
        if st.material is not None and (st.material.touch, st.material.stage) != self._material_touch:
            self.publish.material(st.material)
            self._material_touch = (st.material.touch, st.material.stage)

    def _raise_trips(self, res: StepResult) -> None:
        """An EMCY for every new trip (and last_trip_code); the link-loss fallback's EMCY when it starts
        (cleared when it ends)."""
        stats = self.rt.stats
        fb = res.status.link_fallback
        if res.status.link_fallback_started:
            self.rt.device.raise_emcy(EMCY_LINK_FALLBACK)
            stats.emcy_raised += 1
            log.warning(
                "cycle %d: peer lost while the operator touches: rendering the last identified material "
                "locally (EMCY 0x%04X)",
                stats.cycles - 1,
                EMCY_LINK_FALLBACK,
            )
        elif self._link_fallback and not fb:
            self.rt.device.clear_emcy(EMCY_LINK_FALLBACK)
            log.warning("cycle %d: link-loss fallback ended", stats.cycles - 1)
        self._link_fallback = fb
        for trip in res.status.safety.new_trips:
            code = sf.EMCY_CODES[trip]
            self._w[LAST_TRIP_CODE](code)
            if trip is sf.Trip.PEER_LOST:  # names its peer as the heartbeat consumer names a lost node:
                # the same loss is one EMCY, another watched node's loss its own (telethermo.device.emcy)
                self.rt.device.raise_emcy(code, data=bytes([self.rt.peer_id]), subject=self.rt.peer_id)
            else:
                self.rt.device.raise_emcy(code)
            stats.emcy_raised += 1
            log.warning("cycle %d: trip %s (EMCY 0x%04X)", stats.cycles - 1, trip.value, code)

    def _record(self, sample: RigSample, res: StepResult, peer: PeerValues | None, sync_cycle: int) -> None:
        rt = self.rt
        row = {"t_s": sample.t_s, "sync_cycle": sync_cycle}
        row.update(side_row(rt.prefix, sample, res, peer))
        if rt.parts.truth is not None:
            row.update(truth_row(rt.prefix, rt.parts.rig))
        else:  # hardware: no simulator truth, the same columns (NaN), so every reader reads it
            row.update(dict.fromkeys((c for c in rt.recorder.columns if c not in row), float("nan")))
        rt.recorder.write(row)

    # ------------------------------------------------------------------ the operator's fault reset
    def check_fault_reset(self, value) -> int | None:
        """Validator of fault_reset (0x240A), device lock held: refuse (0x08000022) while a latched trip's
        cause persists in the last sample, so that the operator learns it at once; nothing is cleared then."""
        st = self.state
        if int(value) != 1 or st is None or not st.env.trips or self._last_sample is None:
            return None
        after = clear_faults(self._last_sample, self._last_peer, self.rt.settings.params, st)
        if after.env.trips:
            log.warning(
                "fault reset refused: %s persist", ", ".join(sorted(t.value for t in after.env.trips))
            )
            self._w[FAULT_RESET_BLOCKED_BY](sf.trips_mask(after.env.trips))  # the client reads why
            return ABORT_DEVICE_STATE
        return None

    def on_write(self, ev) -> bool:
        """fault_reset written (validated): carried out at the next cycle. False if not that object."""
        if ev.index != self._fault_reset_index:
            return False
        self._fault_reset_pending = int(ev.value) == 1
        self._w[FAULT_RESET](0)  # a command: reads 0
        return True

    def _operator_fault_reset(
        self, sample: RigSample, peer: PeerValues | None, state: CoreState
    ) -> CoreState:
        """The operator's fault reset (0x240A = 1) at this SYNC: the trips whose cause is gone are cleared
        (their EMCYs too), the envelope restarts bumplessly from the surface."""
        if not state.env.trips:
            log.info("fault reset: nothing latched")
            return state
        new = clear_faults(sample, peer, self.rt.settings.params, state)
        gone = set(state.env.trips) - set(new.env.trips)
        for trip in gone:
            self.rt.device.clear_emcy(sf.EMCY_CODES[trip])
        log.warning(
            "operator fault reset: cleared %s%s",
            ", ".join(sorted(t.value for t in gone)) or "nothing",
            f"; still latched: {', '.join(sorted(t.value for t in new.env.trips))}" if new.env.trips else "",
        )
        self._latched_reported = False
        return new
