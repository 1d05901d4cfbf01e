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

The state, its start and the prediction (stage 1) are in :mod:`telethermo.control.core_state`, the result
types in :mod:`telethermo.control.core_result`, stages 2-6 in :mod:`telethermo.control.core_stages` (3c,
the oscillation guard, here); this module runs them in order and is where the core's public names are
imported from.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import cast

from telethermo.control import core_stages as stages
from telethermo.control import safety as sf
from telethermo.control.contact import ContactState
from telethermo.control.core_result import StepResult, StepStatus
from telethermo.control.core_state import CoreState, init_state, predict, replace_model
from telethermo.control.coreparams import CoreParams, Feedback, RenderPhase, RenderSettings
from telethermo.control.estimators import estimate_flux
from telethermo.control.material_stream import MaterialState, material_step
from telethermo.control.osc_guard import OscGuardState, guard_step
from telethermo.control.passive_bound import PassiveBoundState, bound_step, held_target, passive_flux_W
from telethermo.control.pi import PIGains
from telethermo.control.types import Mode, Outgoing, PeerValues, Role
from telethermo.rig import RigSample

__all__ = [
    "CoreParams",
    "CoreState",
    "Feedback",
    "RenderPhase",
    "RenderSettings",
    "StepResult",
    "StepStatus",
    "clear_faults",
    "init_state",
    "initial_peer",
    "replace_model",
    "step",
]


def step(sample: RigSample, peer: PeerValues | None, params: CoreParams, state: CoreState) -> StepResult:
    """One control step (pure). See the module docstring for the sequence."""
    dt, lim = params.period_s, params.safety
    mode = params.mode
    Ts, Q = sample.T_sensor_C, sample.Q_W

    # 1. model prediction with the measured current (what really flowed)
    T_pred, tick, snap = predict(state, sample.current_A)
    # 2. estimates, credible surface band, contact
    e = stages.estimates(sample, params, state, T_pred)
    cst, est = e.cst, e.est
    # 3. what the mode asks for
    peer_alive = peer is not None and bool(peer.alive)
    peer_ok = peer is not None and sf.peer_valid(lim, peer.estimate_C, peer.flux_W)
    r = stages.request(sample, peer, params, state, e, peer_alive and peer_ok)
    r, link, fallback, fb_started = stages.link(sample, peer, params, state, e, peer_alive and peer_ok, r)
    # 3c. the slave's oscillation guard: kp detuned in contact once the exchange loop rang (osc_guard.py)
    peer_C = cast(PeerValues, peer).estimate_C if peer_alive and peer_ok else math.nan
    r, osc = _osc_guarded(params, state, r, peer_C, cst)
    # 3d. the master's passive bound: the contact target stays where a passive object could take the skin
    # (on the object's side of the touch's start, near the furthest it went towards the object) and the
    # flux it mirrors flows the way a passive object's does
    r, passive = _passively_bounded(params, state, r, peer, peer_alive and peer_ok, est)
    # 4. envelope on setpoint (no peer needed while the link-loss fallback renders); bumpless re-seed of the
    # ramp at the render contact switch
    peer_state = (peer_alive, peer_ok)
    switched, sp, env, env_active, new_trips = stages.envelope(
        params, state, sample, e, T_pred, peer_state, r, fallback
    )
    # 5. controller
    y = T_pred if params.feedback is Feedback.MODEL else est
    err = sp - y
    u_req, pi_st, comps, ident_k, ident_guard = stages.control(sample, params, state, r, err, env, switched)
    # 6. envelope on current (slewed from the previous step's current while a peer trip is latched)
    current, cur_active, pi_st = stages.limit(params, state, e, r, err, u_req, env, pi_st, Q)
    active = env_active + tuple(a for a in cur_active if a not in env_active)
    mid = params.material_id if params.role is Role.SLAVE else None  # the slave's material identification
    identifying = mid is not None
    mat = material_step(mid, state.material, Ts, Q, cst.contact, dt) if mid is not None else state.material
    new_state = CoreState(
        k=state.k + 1,
        t_s=sample.t_s,
        env=env,
        pi=pi_st,
        contact=cst,
        u_prev_A=current,
        source=r.source,
        render_phase=r.phase,
        T_pred_C=T_pred,
        ident_k=ident_k,
        ident_guard=ident_guard,
        pred_tick=tick,
        finger_seen=state.finger_seen or cst.contact or bool(sample.contact),
        pred_snapshot=snap,
        cell=state.cell,
        render_later=r.later_st,
        material=mat,
        link=link,
        osc=osc,
        passive=passive,
    )
    status = StepStatus(
        safety=sf.summarize(env, new_trips, active),
        requested_setpoint_C=r.req,
        setpoint_C=sp,
        feedback_C=y,
        T_pred_C=T_pred,
        estimate_C=est,
        estimate_model_C=e.e_model,
        estimate_flux_C=e.e_flux,
        contact=cst.contact,
        render_phase=r.phase if mode is Mode.RENDER else None,
        pi=comps,
        current_requested_A=u_req,
        material=mat.last if identifying else None,
        link_fallback=fallback,
        link_fallback_started=fb_started,
    )
    out = _outgoing(params, peer, peer_alive and peer_ok, est, Q, cst, mat if identifying else None)
    return StepResult(current_A=current, out=out, state=new_state, status=status)


def _osc_guarded(
    params: CoreParams, state: CoreState, r: stages.Request, peer_C: float, cst: ContactState
) -> tuple[stages.Request, OscGuardState]:
    """Stage 3c (:mod:`telethermo.control.osc_guard`): the guard's next state from the peer's usable
    estimate ``peer_C`` (°C, NaN if none) and the contact; while it detunes (scale < 1) in contact, the
    request's own gains get kp scaled (and the setpoint source key the scale, for a bumpless switch)."""
    osc = guard_step(
        state.osc, peer_C, cst.since_s if cst.contact else None, params.osc_guard_C, params.period_s
    )
    if osc.scale < 1.0 and cst.contact and r.gains == params.gains:  # by value: a copy is the same
        r = replace(
            r,
            gains=PIGains(params.kp_A_per_C * osc.scale, params.ki_A_per_C_s),
            source=r.source + (osc.scale,),
        )
    return r, osc


def _passively_bounded(
    params: CoreParams, state: CoreState, r: stages.Request, peer: PeerValues | None, usable: bool, est: float
) -> tuple[stages.Request, PassiveBoundState]:
    """Stage 3d (:mod:`telethermo.control.passive_bound`; master, telepresence, ``passive_bound``): the
    touch's memory from the probe's contact flag and flux while the peer is usable (kept as it is while
    not), and the contact request's setpoint bounded on the object's side of the touch's start and held
    near the furthest it went towards the object (``held_target``), its mirrored flux kept on the touch's
    side (``passive_flux_W``)."""
    on = params.passive_bound and params.role is Role.MASTER and params.mode is Mode.TELEPRESENCE
    if not (on and usable):
        return r, state.passive
    p = cast(PeerValues, peer)
    st = bound_step(state.passive, bool(p.contact), est, p.flux_W, params.period_s)
    if r.source[1:2] == ("contact",):
        req, st = held_target(st, r.req, params.safety.neutral_C)
        # the mirrored flux on the touch's side: the request's ff = -kQ·flux and eQ = -flux - Q (core_stages)
        turned_W = p.flux_W - passive_flux_W(st, p.flux_W) if math.isfinite(p.flux_W) else 0.0
        r = replace(r, req=req, ff=r.ff + params.kQ_A_per_W * turned_W, eQ=r.eQ + turned_W)
    return r, st


def _outgoing(
    params: CoreParams,
    peer: PeerValues | None,
    peer_usable: bool,
    est: float,
    Q: float,
    cst: ContactState,
    mat: MaterialState | None,
) -> Outgoing:
    """What this node sends (TPDO1 and the contact PDO): its estimate (°C; the peer's own, echoed, while
    free in telepresence with ``echo_peer_when_free``), its flux (W), its contact and, with the slave's
    material identification (``mat``), the last identified material."""
    sent = est
    if (
        params.echo_peer_when_free
        and params.mode is Mode.TELEPRESENCE
        and not cst.contact
        and peer_usable
        and math.isfinite(est)
    ):
        sent = cast(PeerValues, peer).estimate_C
    if mat is None:
        return Outgoing(estimate_C=sent, flux_W=Q, contact=cst.contact)
    ml = mat.last
    return Outgoing(
        estimate_C=sent,
        flux_W=Q,
        contact=cst.contact,
        material_code=ml.code,
        material_beta=ml.beta,
        material_touch=ml.touch,
        material_T_object0_C=ml.T_object0_C,
    )


def clear_faults(
    sample: RigSample, peer: PeerValues | None, params: CoreParams, state: CoreState
) -> CoreState:
    """Operator's fault reset: clear the latched trips whose condition is gone (see safety.clear_trips)."""
    Ts, Q = sample.T_sensor_C, sample.Q_W
    e_flux = estimate_flux(Ts, Q, params.R_sensor_K_per_W)
    cands = (Ts, e_flux)
    s_hi, s_lo = (max(cands), min(cands)) if all(math.isfinite(c) for c in cands) else (math.nan, math.nan)
    lim = params.safety
    peer_alive = peer is not None and bool(peer.alive)
    peer_ok = peer is not None and sf.peer_valid(lim, peer.estimate_C, peer.flux_W)
    inp = sf.EnvelopeInput(
        Ts,
        Q,
        sample.T_sink_C,
        sample.current_A,
        s_hi,
        s_lo,
        state.T_pred_C,
        params.mode is Mode.TELEPRESENCE,
        peer_alive,
        peer_ok,
    )
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
