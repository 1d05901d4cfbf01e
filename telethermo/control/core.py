"""The control core: one pure step function per SYNC (DESIGN.md §2), the same offline and in a node.

    params = CoreParams(role=Role.MASTER, mode=Mode.TELEPRESENCE, period_s=0.01, ...)
    state = init_state(params, predictor_or_model, first_sample)
    res = step(sample, peer, params, state)   # res.current_A, res.out, res.state, res.status

Per step (guiatni eq. 30-35, yamamoto §III):

1. advance the TEM model with the measured current -> T_pred (if a predictor is given);
2. estimate the contact-side temperature (:mod:`telethermo.control.estimators`): the master's estimate is
   the finger's T_f, the slave's the object's T_o; detect contact from the flux;
3. the mode gives the requested setpoint and the feed-forward: TELEPRESENCE: setpoint = the peer's estimate,
   feed-forward = -kQ·Q_peer (the pad delivers the mirror of the flux the peer's contact draws: eq. 34/35
   with the rig sign convention, so kQ > 0); optional flux loop towards -Q_peer; RENDER: T_pad0 (eq. 7)
   until contact is detected, then T_contact (eq. 1), current held ``settle_s``; IDLE: current ramps to 0;
   IDENTIFY: the identification experiment ``identify`` (:class:`telethermo.ident.plan.IdentifyPlan`: rest,
   training PRBS, held-out PRBS, then 0 A), sample by sample from the step that entered the mode, with the
   plan's guard (sign flipped near the envelope) - the same currents as the offline experiment;
4. the safety envelope (:mod:`telethermo.control.safety`) judges the sample and the peer, ramps and clamps
   the setpoint; a bad peer value is replaced by the ramp to neutral before it can reach the PI;
5. PI + feed-forward with anti-windup including the feed-forward (:mod:`telethermo.control.pi`), bumpless on
   every change of mode or setpoint source;
6. the envelope limits the current (cut, trip slew, surface guard with taper, |I| <= 0.8·Imax).

``step`` is pure: the same (sample, peer, params, state) give the same result. The predictor is the only
stateful object; its state is carried in :class:`CoreState` through ``snapshot()``/``restore()`` when the
predictor offers them (``telethermo.ident``'s NarmaPredictor does); a predictor without them makes a state
single-use (re-using an old state raises). Pass a *model* (not one predictor object) when both sides share
it: each ``init_state`` then builds its own predictor.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, cast

from telethermo.control import safety as sf
from telethermo.control.contact import ContactState, contact_step
from telethermo.control.coreparams import NO_GAINS, CoreParams, Feedback, RenderPhase, RenderSettings
from telethermo.control.estimators import (Estimator, SnapshotPredictor, TemperaturePredictor, as_predictor,
                                          estimate_flux, estimate_model)
from telethermo.control.later_phase import later_setpoint, later_start
from telethermo.control.link_fallback import LinkState, fallback_gains, link_step
from telethermo.control.material_stream import MaterialEstimate, MaterialState, material_step, prepare
from telethermo.control.osc_guard import OscGuardState, guard_step
from telethermo.control.pi import PIComponents, PIGains, PIState, bumpless, pi_step
from telethermo.control.types import Mode, Outgoing, PeerValues, Role
from telethermo.ident.plan import guarded_current
from telethermo.rig import RigSample

__all__ = ["CoreParams", "CoreState", "Feedback", "RenderPhase", "RenderSettings", "StepResult", "StepStatus",
           "clear_faults", "init_state", "initial_peer", "replace_model", "step"]


class _PredictorCell:
    """Holds the predictor and which state-tick it is at (private to this module)."""

    __slots__ = ("predictor", "tick", "can_snapshot")

    def __init__(self, predictor: TemperaturePredictor) -> None:
        self.predictor = predictor
        self.tick = 0
        self.can_snapshot = callable(getattr(predictor, "snapshot", None)) and \
            callable(getattr(predictor, "restore", None))


@dataclass(frozen=True, slots=True)
class CoreState:
    """Everything ``step`` remembers. Treat as opaque; fields are for introspection and tests.

    Attributes:
        k: steps taken. t_s: time of the last sample, s. u_prev_A: the previous step's current command, A.
        env: safety envelope state. pi: PI integrator. contact: contact detector state.
        source: key of the setpoint source of the previous step (mode, phase) for bumpless switching.
        render_phase: :class:`RenderPhase` (RENDER mode).
        T_pred_C: the last model prediction, °C (NaN without a model).
        ident_k: IDENTIFY: steps since the experiment started (0 outside IDENTIFY); the plan is done once
            it reaches ``identify.total`` (the count goes on while 0 A is held);
        ident_guard: IDENTIFY: samples whose current the plan's guard flipped or cut.
        finger_seen: something has touched the pad since the start (its detector or the rig's flag): once
            the finger is lifted, air rendering holds neutral instead (before any finger it renders air,
            and both pads rest at ambient).
        render_later: RENDER in contact: (the render's ``LaterPhase``, its model state); restarted at each
            touch and whenever the rendered object changes.
        material: (slave) the material identification's collector and last result.
        link: (master, telepresence) the graceful link loss's memory (:mod:`telethermo.control.link_fallback`).
        osc: (slave) the oscillation guard's memory and kp scale (:mod:`telethermo.control.osc_guard`).
    """

    k: int
    t_s: float
    env: sf.EnvelopeState
    pi: PIState
    contact: ContactState
    u_prev_A: float
    source: tuple[Any, ...]
    render_phase: RenderPhase
    T_pred_C: float
    ident_k: int = 0
    ident_guard: int = 0
    finger_seen: bool = False
    pred_tick: int = 0
    pred_snapshot: Any = None
    render_later: Any = None
    cell: _PredictorCell | None = field(default=None, compare=False, repr=False)
    material: MaterialState = field(default_factory=MaterialState)
    link: LinkState = field(default_factory=LinkState)
    osc: OscGuardState = field(default_factory=OscGuardState)


@dataclass(frozen=True, slots=True)
class StepStatus:
    """What happened in one step (for the node's status/EMCY objects and the recordings).

    Attributes:
        safety: :class:`telethermo.control.safety.EnvelopeStatus` (state, trips, new_trips,
            error_register, limits_active; ``.emcy_codes`` / ``.new_emcy_codes``).
        requested_setpoint_C: what the mode asked for, °C (NaN if nothing, e.g. a bad peer).
        setpoint_C: after the envelope, °C.
        feedback_C: what the PI compared with the setpoint, °C.
        T_pred_C: model prediction, °C (NaN without a model).
        estimate_C: the estimate sent to the peer, °C; estimate_model_C, estimate_flux_C: both kinds.
        contact: contact detected from the signals.
        render_phase: RENDER phase (PRESET/CONTACT) or None.
        pi: :class:`telethermo.control.pi.PIComponents`.
        current_requested_A: the controller's output before the envelope's current limits, A.
        material: (slave) the last identified material (None on the master or with identification off).
        link_fallback: (master) the slave is lost and the master renders the last identified material itself;
            link_fallback_started: it started in this step (raise its EMCY once).
    """

    safety: sf.EnvelopeStatus
    requested_setpoint_C: float
    setpoint_C: float
    feedback_C: float
    T_pred_C: float
    estimate_C: float
    estimate_model_C: float
    estimate_flux_C: float
    contact: bool
    render_phase: RenderPhase | None
    pi: PIComponents
    current_requested_A: float
    material: MaterialEstimate | None = None
    link_fallback: bool = False
    link_fallback_started: bool = False

    # convenience for the node layer
    @property
    def safety_state(self) -> sf.SafetyState:
        return self.safety.state

    @property
    def trips(self) -> tuple[sf.Trip, ...]:
        return self.safety.trips

    @property
    def new_emcy_codes(self) -> tuple[int, ...]:
        return self.safety.new_emcy_codes

    @property
    def error_register(self) -> int:
        return self.safety.error_register


@dataclass(frozen=True, slots=True)
class StepResult:
    """Output of :func:`step`: apply ``current_A``, send ``out`` (TPDO1), keep ``state``."""

    current_A: float
    out: Outgoing
    state: CoreState
    status: StepStatus


def init_state(params: CoreParams, predictor_or_model: Any, first_sample: RigSample) -> CoreState:
    """Initial state from the first sample (the pad assumed at rest at ``first_sample.T_sensor_C``).

    ``predictor_or_model``: a :class:`TemperaturePredictor`, a model (``telethermo.ident.TemModel``)
    or None (only with the FLUX estimator and ESTIMATE feedback).
    """
    if predictor_or_model is None and (params.estimator is not Estimator.FLUX or params.feedback is Feedback.MODEL):
        raise ValueError(f"init_state: estimator {params.estimator.value!r} / feedback {params.feedback.value!r} "
                         "needs a TEM model (predictor_or_model is None)")
    T0 = first_sample.T_sensor_C if math.isfinite(first_sample.T_sensor_C) else params.safety.neutral_C
    pred = as_predictor(predictor_or_model, T0)
    cell = _PredictorCell(pred) if pred is not None else None
    snap = cast(SnapshotPredictor, pred).snapshot() if cell is not None and cell.can_snapshot else None
    # bumpless from the current the rig is already driving (a display that was holding its pad)
    I0 = first_sample.current_A if math.isfinite(first_sample.current_A) else 0.0
    I0 = min(max(I0, -params.safety.I_cool_limit_A), params.safety.I_limit_A)
    if params.role is Role.SLAVE and params.material_id is not None:
        prepare(params.material_id, params.period_s)           # the fit's constants, outside any touch's cycle
    return CoreState(k=0, t_s=first_sample.t_s, env=sf.EnvelopeState(), pi=PIState(0.0), contact=ContactState(),
                     u_prev_A=I0, source=(), render_phase=RenderPhase.PRESET, T_pred_C=T0 if pred else math.nan,
                     pred_tick=0, pred_snapshot=snap, cell=cell)


def replace_model(state: CoreState, predictor_or_model: Any, T0_C: float) -> CoreState:
    """``state`` with a new TEM model (or none): its predictor starts at rest at ``T0_C`` (°C), as
    :func:`init_state` starts one. For a model loaded into a running node (the pad may not be at rest:
    T_pred then carries the pad's transient until it decays). None is only for parameters that need
    no model (FLUX estimator, ESTIMATE feedback): the caller checks."""
    pred = as_predictor(predictor_or_model, T0_C)
    cell = _PredictorCell(pred) if pred is not None else None
    snap = cast(SnapshotPredictor, pred).snapshot() if cell is not None and cell.can_snapshot else None
    return replace(state, cell=cell, pred_tick=0, pred_snapshot=snap, T_pred_C=T0_C if pred is not None else math.nan)


def _predict(state: CoreState, current_A: float) -> tuple[float, int, Any]:
    """T_pred for this sample. ``current_A``: the current held since the previous sample (the sample's
    measured current). The first sample is the predictor's rest state (no step yet)."""
    cell = state.cell
    if cell is None:
        return math.nan, state.pred_tick, None
    if state.k == 0:
        return state.T_pred_C, state.pred_tick, state.pred_snapshot
    if cell.tick != state.pred_tick:
        if not cell.can_snapshot:
            raise RuntimeError("control.core.step: this CoreState was already used and its predictor cannot be "
                               "restored (give the predictor snapshot()/restore(), or use each state once)")
        cast(SnapshotPredictor, cell.predictor).restore(state.pred_snapshot)
    T = float(cell.predictor.step(current_A if math.isfinite(current_A) else 0.0))
    cell.tick = state.pred_tick + 1
    snap = cast(SnapshotPredictor, cell.predictor).snapshot() if cell.can_snapshot else None
    return T, cell.tick, snap


@dataclass(frozen=True, slots=True)
class _Estimates:
    """Stage 2: the estimates (°C), the credible surface band (°C) and the contact detector's state."""

    est: float
    e_flux: float
    e_model: float
    s_hi: float
    s_lo: float
    cst: ContactState


@dataclass(frozen=True, slots=True)
class _Request:
    """Stage 3: what the mode asks for: setpoint (°C), feed-forward (A), flux error (W), the gains in use,
    the render phase, whether to hold the current, the later-phase model and the setpoint source key."""

    req: float
    ff: float
    eQ: float
    gains: Any
    fg: Any
    phase: RenderPhase
    hold_current: bool
    later_st: Any
    source: tuple[Any, ...]


def _estimates(sample: RigSample, params: CoreParams, state: CoreState, T_pred: float) -> _Estimates:
    Ts, Q = sample.T_sensor_C, sample.Q_W
    e_flux = estimate_flux(Ts, Q, params.R_sensor_K_per_W)
    e_model = estimate_model(Ts, T_pred) if math.isfinite(T_pred) else math.nan
    if params.estimator is Estimator.FLUX:
        est = e_flux
    elif params.estimator is Estimator.MODEL:
        est = e_model
    else:
        w = params.fused_weight
        est = w * e_model + (1.0 - w) * e_flux
    cst = contact_step(params.contact, state.contact, Q, sample.contact, params.period_s, Ts)
    # credible band: the pad stack (both sensor faces); with a finger on the display, the skin's bound (docs)
    skin = params.safety.protects == "skin" and cst.contact and bool(sample.contact)   # both see a finger
    cands = (Ts, e_flux, est) if skin else (Ts, e_flux, Ts + 0.5 * Q * params.R_sensor_K_per_W, est)
    if all(math.isfinite(c) for c in cands):
        s_hi, s_lo = max(cands), min(cands)
    else:
        s_hi = s_lo = math.nan
    return _Estimates(est, e_flux, e_model, s_hi, s_lo, cst)


def _telepresence_request(sample: RigSample, peer: PeerValues | None, params: CoreParams, state: CoreState,
                          e: _Estimates, peer_usable: bool) -> _Request:
    """TELEPRESENCE: the peer's estimate and the mirror of its flux (eq. 34/35); air rendering on the master."""
    lim, Q, cst = params.safety, sample.Q_W, e.cst
    gains, fg = params.gains, params.flux_gains
    ff = eQ = 0.0
    phase_t = "contact"
    if peer_usable:
        peer = cast(PeerValues, peer)      # usable: there is one
        req = peer.estimate_C
        ff = -params.kQ_A_per_W * peer.flux_W
        eQ = -peer.flux_W - Q
        if params.air_rendering and params.role is Role.MASTER:
            if not (cst.contact or sample.contact) and state.finger_seen:
                phase_t = "no_finger"      # the finger was lifted: hold neutral, no flux terms
                req, ff, eQ, fg = lim.neutral_C, 0.0, 0.0, None
            elif peer.contact is False or not (cst.contact or sample.contact):
                phase_t = "air"            # the probe touches nothing: render air
                req, ff = e.est, 0.0
                eQ = -params.G_air_W_per_K * (e.est - params.T_air_C) - Q
                gains, fg = NO_GAINS, params._air_gains
    else:
        req = math.nan
    return _Request(req, ff, eQ, gains, fg, state.render_phase, False, None, (params.mode, phase_t))


def _render_request(sample: RigSample, params: CoreParams, state: CoreState, e: _Estimates) -> _Request:
    """RENDER: T_pad0 (eq. 7) before contact, T_contact (eq. 1) and the later-phase model in contact."""
    rs, cst, Q = cast(RenderSettings, params.render), e.cst, sample.Q_W
    phase = RenderPhase.CONTACT if cst.contact else RenderPhase.PRESET
    req = rs.T_contact_C if phase is RenderPhase.CONTACT else rs.T_pad0_C
    later_st = None
    if phase is RenderPhase.CONTACT and rs.later is not None:   # after the first instant (eq. 1)
        prev = state.render_later       # (the model it belongs to, its state): restart on a new touch/object
        ls = prev[1] if prev is not None and prev[0] is rs.later and state.render_phase is phase else \
            later_start(rs.later, rs.T_object0_C)
        req, ls = later_setpoint(rs.later, ls, rs.T_contact_C, rs.T_finger0_C, rs.T_object0_C, cst.since_s,
                                 -Q, e.e_flux)
        later_st = (rs.later, ls)
    settling = phase is RenderPhase.CONTACT and cst.since_s < rs.settle_s - 1e-12
    hold_current = phase is RenderPhase.CONTACT and (rs.hold_current_on_contact or settling)
    ff = params.kQ_render_A_per_W * Q if phase is RenderPhase.CONTACT else 0.0
    return _Request(req, ff, 0.0, params.gains, None, phase, hold_current, later_st, (params.mode, phase, settling))


def _request(sample: RigSample, peer: PeerValues | None, params: CoreParams, state: CoreState, e: _Estimates,
             peer_usable: bool) -> _Request:
    """Stage 3: what the mode asks for."""
    if params.mode is Mode.TELEPRESENCE:
        return _telepresence_request(sample, peer, params, state, e, peer_usable)
    if params.mode is Mode.RENDER:
        return _render_request(sample, params, state, e)
    # IDLE, IDENTIFY: the setpoint follows the surface (keeps the envelope's ramp bumpless)
    return _Request(0.5 * (e.s_hi + e.s_lo), 0.0, 0.0, params.gains, None, state.render_phase, False, None,
                    (params.mode,))


def _link(sample: RigSample, peer: PeerValues | None, params: CoreParams, state: CoreState, e: _Estimates,
          peer_usable: bool, r: _Request) -> tuple[_Request, LinkState, bool, bool]:
    """Stage 3b (master, telepresence): graceful link loss (:mod:`telethermo.control.link_fallback`): while it
    renders, its setpoint replaces the request (a temperature PI, no flux terms: ``fallback_gains``).
    Returns the request, the link state, whether the fallback renders and whether it started now."""
    if params.role is not Role.MASTER or params.mode is not Mode.TELEPRESENCE:
        return r, state.link, False, False
    lr = link_step(state.link, peer, peer_usable=peer_usable, contact=e.cst.contact or bool(sample.contact),
                   est_C=e.est, q_in_W=-sample.Q_W, T_surface_est_C=e.e_flux, render_s=params.link_loss_render_s,
                   dt_s=params.period_s, peer_tripped=bool(state.env.trips & sf.PEER_TRIPS))
    if lr.active:
        r = _Request(lr.setpoint_C, 0.0, 0.0, fallback_gains(params.kp_A_per_C), None, state.render_phase, False, None,
                     (params.mode, "link_fallback"))
    return r, lr.state, lr.active, lr.started


def _seeded_envelope(params: CoreParams, state: CoreState, r: _Request, est: float, switched: bool) -> sf.EnvelopeState:
    """Stage 4's bumpless re-seed of the ramp at the render contact switch.

    yamamoto's command switch: at the touch the skin (at T_finger0) and the pad (at T_pad0) meet at
    T_contact, which lies between the two by eq. 3/7: the setpoint jumps there without the ramp (the jump is
    the natural contact, not a drive). Otherwise restart from the surface.
    """
    env0 = state.env
    if switched and params.mode is Mode.RENDER and r.phase is RenderPhase.CONTACT and r.source[2]:
        rs, lim = cast(RenderSettings, params.render), params.safety
        lo_c, hi_c = sorted((rs.T_pad0_C, rs.T_finger0_C))
        T_c = rs.T_contact_C
        seed = T_c if lo_c - 1e-9 <= T_c <= hi_c + 1e-9 else est
        if math.isfinite(seed):
            env0 = replace(env0, setpoint_C=min(max(seed, lim.T_min_C), lim.T_max_C))
    return env0


def _control(sample: RigSample, params: CoreParams, state: CoreState, r: _Request, err: float,
             env: sf.EnvelopeState, switched: bool) -> tuple[float, PIState, PIComponents, int, int]:
    """Stage 5: the current the mode's controller asks for, A, its PI state and components, and the
    identification experiment's counters."""
    dt, lim = params.period_s, params.safety
    I_lim, I_cool = lim.I_limit_A, lim.I_cool_limit_A
    pi_st = state.pi
    if switched or env.cut:
        pi_st = bumpless(r.gains, state.u_prev_A if not env.cut else 0.0, err, r.ff, -I_cool, I_lim,
                         flux_error_W=r.eQ, flux_gains=r.fg)
    ident_k, ident_guard = 0, 0
    if params.mode is Mode.IDLE:
        stepA = params.idle_ramp_A_per_s * dt
        u_req = min(max(0.0, state.u_prev_A - stepA), state.u_prev_A + stepA) if math.isfinite(state.u_prev_A) else 0.0
        comps = PIComponents(0.0, 0.0, 0.0, u_req, u_req, False)
    elif params.mode is Mode.IDENTIFY:
        plan = params.identify
        j = 0 if switched else state.ident_k
        guard = 0 if switched else state.ident_guard
        if j < plan.total:
            u_req, guarded = guarded_current(plan.current_at(j), sample.T_sensor_C, I_limit_A=I_lim,
                                             T_min_C=lim.T_min_C, T_max_C=lim.T_max_C, margin_C=plan.margin_C)
            ident_k, ident_guard = j + 1, guard + int(guarded)
        else:  # done: hold 0 A until the mode changes (the count goes on: ident_k > total means done)
            u_req, ident_k, ident_guard = 0.0, j + 1, guard
        comps = PIComponents(0.0, 0.0, 0.0, u_req, u_req, False)
    elif r.hold_current:
        u_req = state.u_prev_A
        comps = PIComponents(0.0, pi_st.integral_A, 0.0, u_req, u_req, False)
    else:
        u_req, pi_st, comps = pi_step(r.gains, pi_st, err, r.ff, dt, -I_cool, I_lim, flux_error_W=r.eQ,
                                      flux_gains=r.fg)
    return u_req, pi_st, comps, ident_k, ident_guard


def step(sample: RigSample, peer: PeerValues | None, params: CoreParams, state: CoreState) -> StepResult:
    """One control step (pure). See the module docstring for the sequence."""
    dt, lim = params.period_s, params.safety
    I_lim, I_cool = lim.I_limit_A, lim.I_cool_limit_A
    mode = params.mode
    Ts, Q = sample.T_sensor_C, sample.Q_W

    # 1. model prediction with the measured current (what really flowed)
    T_pred, tick, snap = _predict(state, sample.current_A)
    # 2. estimates, credible surface band, contact
    e = _estimates(sample, params, state, T_pred)
    cst, est = e.cst, e.est
    # 3. what the mode asks for
    peer_alive = peer is not None and bool(peer.alive)
    peer_ok = peer is not None and sf.peer_valid(lim, peer.estimate_C, peer.flux_W)
    r = _request(sample, peer, params, state, e, peer_alive and peer_ok)
    r, link, fallback, fb_started = _link(sample, peer, params, state, e, peer_alive and peer_ok, r)
    # 3c. the slave's oscillation guard: kp detuned in contact once the exchange loop rang (osc_guard.py)
    osc = guard_step(state.osc, cast(PeerValues, peer).estimate_C if peer_alive and peer_ok else math.nan,
                     cst.since_s if cst.contact else None, params.osc_guard_C, dt)
    if osc.scale < 1.0 and cst.contact and r.gains is params.gains:
        r = replace(r, gains=PIGains(params.kp_A_per_C * osc.scale, params.ki_A_per_C_s),
                    source=r.source + (osc.scale,))
    # 4. envelope on setpoint (no peer needed while the link-loss fallback renders); bumpless re-seed of the
    # ramp at the render contact switch
    env_in = sf.EnvelopeInput(Ts, Q, sample.T_sink_C, sample.current_A, e.s_hi, e.s_lo, T_pred,
                              mode is Mode.TELEPRESENCE and not fallback, peer_alive, peer_ok, fallback)
    switched = r.source != state.source
    env0 = _seeded_envelope(params, state, r, est, switched)
    sp, env, env_active, new_trips = sf.envelope_step(lim, env0, env_in, r.req, dt)
    # 5. controller
    y = T_pred if params.feedback is Feedback.MODEL else est
    err = sp - y
    u_req, pi_st, comps, ident_k, ident_guard = _control(sample, params, state, r, err, env, switched)
    # 6. envelope on current (slewed from the previous step's current while a peer trip is latched)
    current, cur_active = sf.limit_current(lim, env, u_req, e.s_hi, e.s_lo, state.u_prev_A, dt, Q)
    if current != u_req:
        # the envelope overrode the controller: keep the integrator consistent (no windup behind it)
        pi_st = bumpless(r.gains, current, err, r.ff, -I_cool, I_lim, flux_error_W=r.eQ, flux_gains=r.fg)

    active = env_active + tuple(a for a in cur_active if a not in env_active)
    mid = params.material_id if params.role is Role.SLAVE else None    # the slave's material identification
    identifying = mid is not None
    mat = material_step(mid, state.material, Ts, Q, cst.contact, dt) if mid is not None else state.material
    new_state = CoreState(k=state.k + 1, t_s=sample.t_s, env=env, pi=pi_st, contact=cst, u_prev_A=current,
                          source=r.source, render_phase=r.phase, T_pred_C=T_pred, ident_k=ident_k,
                          ident_guard=ident_guard, pred_tick=tick,
                          finger_seen=state.finger_seen or cst.contact or bool(sample.contact),
                          pred_snapshot=snap, cell=state.cell, render_later=r.later_st, material=mat, link=link,
                          osc=osc)
    status = StepStatus(safety=sf.summarize(env, new_trips, active), requested_setpoint_C=r.req, setpoint_C=sp,
                        feedback_C=y, T_pred_C=T_pred, estimate_C=est, estimate_model_C=e.e_model,
                        estimate_flux_C=e.e_flux, contact=cst.contact,
                        render_phase=r.phase if mode is Mode.RENDER else None, pi=comps, current_requested_A=u_req,
                        material=mat.last if identifying else None, link_fallback=fallback,
                        link_fallback_started=fb_started)
    sent = est
    if (params.echo_peer_when_free and mode is Mode.TELEPRESENCE and not cst.contact and peer_ok and peer_alive
            and math.isfinite(est)):
        sent = cast(PeerValues, peer).estimate_C
    ml = mat.last
    out = Outgoing(estimate_C=sent, flux_W=Q, contact=cst.contact, material_code=ml.code, material_beta=ml.beta,
                   material_touch=ml.touch, material_T_object0_C=ml.T_object0_C) if identifying else Outgoing(estimate_C=sent, flux_W=Q, contact=cst.contact)
    return StepResult(current_A=current, out=out, state=new_state, status=status)


def clear_faults(sample: RigSample, peer: PeerValues | None, params: CoreParams, state: CoreState) -> CoreState:
    """Operator's fault reset: clear the latched trips whose condition is gone (see safety.clear_trips)."""
    Ts, Q = sample.T_sensor_C, sample.Q_W
    e_flux = estimate_flux(Ts, Q, params.R_sensor_K_per_W)
    cands = (Ts, e_flux)
    s_hi, s_lo = (max(cands), min(cands)) if all(math.isfinite(c) for c in cands) else (math.nan, math.nan)
    lim = params.safety
    peer_alive = peer is not None and bool(peer.alive)
    peer_ok = peer is not None and sf.peer_valid(lim, peer.estimate_C, peer.flux_W)
    inp = sf.EnvelopeInput(Ts, Q, sample.T_sink_C, sample.current_A, s_hi, s_lo, state.T_pred_C,
                           params.mode is Mode.TELEPRESENCE, peer_alive, peer_ok)
    env = sf.clear_trips(lim, state.env, inp)
    # a bumpless restart of the setpoint source, except for an identification experiment, which goes on
    # with its plan (its record shows the cut; telethermo identify refuses such a record)
    return replace(state, env=env, source=() if params.mode is not Mode.IDENTIFY else state.source)


def initial_peer(first_sample: RigSample) -> PeerValues:
    """Peer values for cycle 0, before any PDO arrived: the own first T_sensor and 0 W, not fresh.

    Both the offline session and the nodes use this, so the two paths start identically.
    """
    T = first_sample.T_sensor_C if math.isfinite(first_sample.T_sensor_C) else math.nan
    return PeerValues(estimate_C=T, flux_W=0.0, fresh=False, alive=True)
