"""The stages of one control step (:func:`telethermo.control.core.step`, numbered as in its docstring):
2. the estimates, the credible surface band and contact (:func:`estimates`); 3. what the mode asks for
(:func:`request`), 3b. the master's graceful link loss (:func:`link`); 4. the envelope on the setpoint
(:func:`envelope`), with the bumpless re-seed of its ramp at the render contact switch
(:func:`seeded_envelope`); 5. the mode's controller (:func:`control`); 6. the envelope on the current
(:func:`limit`). Each is a pure function of (sample, peer, params, state) and the earlier stages.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, cast

from telethermo.control import safety as sf
from telethermo.control.contact import ContactState, contact_step
from telethermo.control.core_state import CoreState
from telethermo.control.coreparams import NO_GAINS, CoreParams, RenderPhase, RenderSettings
from telethermo.control.estimators import Estimator, estimate_flux, estimate_model
from telethermo.control.later_phase import later_setpoint, later_start
from telethermo.control.link_fallback import LinkState, fallback_gains, link_step
from telethermo.control.pi import PIComponents, PIState, bumpless, pi_step
from telethermo.control.types import Mode, PeerValues, Role
from telethermo.control.virtual_finger import VirtualFinger, vf_start, vf_step
from telethermo.ident.plan import guarded_current
from telethermo.rig import RigSample

__all__ = [
    "Estimates",
    "Request",
    "estimates",
    "request",
    "link",
    "seeded_envelope",
    "envelope",
    "control",
    "limit",
]


@dataclass(frozen=True, slots=True)
class Estimates:
    """Stage 2: the estimates (°C), the credible surface band (°C), the contact detector's state and the pad
    stack's band (``k_hi``, ``k_lo``: the sensor, both its faces and the estimate, °C)."""

    est: float
    e_flux: float
    e_model: float
    s_hi: float
    s_lo: float
    cst: ContactState
    k_hi: float = math.nan
    k_lo: float = math.nan


@dataclass(frozen=True, slots=True)
class Request:
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


def estimates(sample: RigSample, params: CoreParams, state: CoreState, T_pred: float) -> Estimates:
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
    skin = params.safety.protects == "skin" and cst.contact and bool(sample.contact)  # both see a finger
    stack = (Ts, e_flux, Ts + 0.5 * Q * params.R_sensor_K_per_W, est)
    cands = (Ts, e_flux, est) if skin else stack
    if all(math.isfinite(c) for c in stack):
        s_hi, s_lo = max(cands), min(cands)
        k_hi, k_lo = max(stack), min(stack)
    else:
        s_hi = s_lo = k_hi = k_lo = math.nan
    return Estimates(est, e_flux, e_model, s_hi, s_lo, cst, k_hi, k_lo)


def _telepresence_request(
    sample: RigSample,
    peer: PeerValues | None,
    params: CoreParams,
    state: CoreState,
    e: Estimates,
    peer_usable: bool,
) -> Request:
    """TELEPRESENCE: the peer's estimate and the mirror of its flux (eq. 34/35); air rendering on the
    master."""
    lim, Q, cst = params.safety, sample.Q_W, e.cst
    gains, fg = params.gains, params.flux_gains
    ff = eQ = 0.0
    phase_t = "contact"
    if peer_usable:
        peer = cast(PeerValues, peer)  # usable: there is one
        req = peer.estimate_C
        ff = -params.kQ_A_per_W * peer.flux_W
        eQ = -peer.flux_W - Q
        if params.air_rendering and params.role is Role.MASTER:
            if not (cst.contact or sample.contact) and state.finger_seen:
                phase_t = "no_finger"  # the finger was lifted: hold neutral, no flux terms
                req, ff, eQ, fg = lim.neutral_C, 0.0, 0.0, None
            elif peer.contact is False or not (cst.contact or sample.contact):
                phase_t = "air"  # the probe touches nothing: render air
                req, ff = e.est, 0.0
                eQ = -params.G_air_W_per_K * (e.est - params.T_air_C) - Q
                gains, fg = NO_GAINS, params._air_gains
    else:
        req = math.nan
    vf_st = None
    vf = params.virtual_finger
    if vf is not None and peer_usable and cst.contact:  # the probe renders a finger to the object
        prev = state.render_later
        same = prev is not None and isinstance(prev[0], VirtualFinger) and prev[0].b == vf.b
        x = prev[1] if same else vf_start(vf, cast(PeerValues, peer).estimate_C)
        x, req = vf_step(vf, x, Q)
        vf_st, ff, eQ, fg, phase_t = (vf, x), 0.0, 0.0, None, "virtual_finger"
    return Request(req, ff, eQ, gains, fg, state.render_phase, False, vf_st, (params.mode, phase_t))


def _render_request(sample: RigSample, params: CoreParams, state: CoreState, e: Estimates) -> Request:
    """RENDER: T_pad0 (eq. 7) before contact, T_contact (eq. 1) and the later-phase model in contact."""
    rs, cst, Q = cast(RenderSettings, params.render), e.cst, sample.Q_W
    phase = RenderPhase.CONTACT if cst.contact else RenderPhase.PRESET
    req = rs.T_contact_C if phase is RenderPhase.CONTACT else rs.T_pad0_C
    later_st = None
    if phase is RenderPhase.CONTACT and rs.later is not None:  # after the first instant (eq. 1)
        prev = state.render_later  # (the model it belongs to, its state): restart on a new touch/object
        ls = (
            prev[1]
            if prev is not None and prev[0] is rs.later and state.render_phase is phase
            else later_start(rs.later, rs.T_object0_C)
        )
        req, ls = later_setpoint(
            rs.later, ls, rs.T_contact_C, rs.T_finger0_C, rs.T_object0_C, cst.since_s, -Q, e.e_flux
        )
        later_st = (rs.later, ls)
    settling = phase is RenderPhase.CONTACT and cst.since_s < rs.settle_s - 1e-12
    hold_current = phase is RenderPhase.CONTACT and (rs.hold_current_on_contact or settling)
    ff = params.kQ_render_A_per_W * Q if phase is RenderPhase.CONTACT else 0.0
    return Request(
        req, ff, 0.0, params.gains, None, phase, hold_current, later_st, (params.mode, phase, settling)
    )


def request(
    sample: RigSample,
    peer: PeerValues | None,
    params: CoreParams,
    state: CoreState,
    e: Estimates,
    peer_usable: bool,
) -> Request:
    """Stage 3: what the mode asks for."""
    if params.mode is Mode.TELEPRESENCE:
        return _telepresence_request(sample, peer, params, state, e, peer_usable)
    if params.mode is Mode.RENDER:
        return _render_request(sample, params, state, e)
    # IDLE, IDENTIFY: the setpoint follows the surface (keeps the envelope's ramp bumpless)
    return Request(
        0.5 * (e.s_hi + e.s_lo), 0.0, 0.0, params.gains, None, state.render_phase, False, None, (params.mode,)
    )


def link(
    sample: RigSample,
    peer: PeerValues | None,
    params: CoreParams,
    state: CoreState,
    e: Estimates,
    peer_usable: bool,
    r: Request,
) -> tuple[Request, LinkState, bool, bool]:
    """Stage 3b (master, telepresence): graceful link loss (:mod:`telethermo.control.link_fallback`): while it
    renders, its setpoint replaces the request (a temperature PI, no flux terms: ``fallback_gains``).
    Returns the request, the link state, whether the fallback renders and whether it started now."""
    if params.role is not Role.MASTER or params.mode is not Mode.TELEPRESENCE:
        return r, state.link, False, False
    lr = link_step(
        state.link,
        peer,
        peer_usable=peer_usable,
        contact=e.cst.contact or bool(sample.contact),
        est_C=e.est,
        q_in_W=-sample.Q_W,
        T_surface_est_C=e.e_flux,
        render_s=params.link_loss_render_s,
        dt_s=params.period_s,
        peer_tripped=bool(state.env.trips & sf.PEER_TRIPS),
    )
    if lr.active:
        r = Request(
            lr.setpoint_C,
            0.0,
            0.0,
            fallback_gains(params.kp_A_per_C),
            None,
            state.render_phase,
            False,
            None,
            (params.mode, "link_fallback"),
        )
    return r, lr.state, lr.active, lr.started


def seeded_envelope(
    params: CoreParams, state: CoreState, r: Request, est: float, switched: bool
) -> sf.EnvelopeState:
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


def envelope(
    params: CoreParams,
    state: CoreState,
    sample: RigSample,
    e: Estimates,
    T_pred: float,
    peer_state: tuple[bool, bool],
    r: Request,
    fallback: bool,
) -> tuple[bool, float, sf.EnvelopeState, tuple[str, ...], frozenset[sf.Trip]]:
    """Stage 4: the envelope on the setpoint (no peer needed while the link-loss fallback renders), with the
    bumpless re-seed of the ramp at the render contact switch. ``T_pred``: the model's prediction, °C;
    ``peer_state``: (alive, values valid). Returns whether the setpoint source switched, the setpoint (°C),
    the envelope's state, the limits that acted and the trips raised in this step."""
    peer_alive, peer_ok = peer_state
    required = params.mode is Mode.TELEPRESENCE and not fallback
    env_in = sf.EnvelopeInput(
        sample.T_sensor_C,
        sample.Q_W,
        sample.T_sink_C,
        sample.current_A,
        e.s_hi,
        e.s_lo,
        T_pred,
        required,
        peer_alive,
        peer_ok,
        fallback,
        e.k_hi,
        e.k_lo,
    )
    switched = r.source != state.source
    env0 = seeded_envelope(params, state, r, e.est, switched)
    sp, env, env_active, new_trips = sf.envelope_step(params.safety, env0, env_in, r.req, params.period_s)
    return switched, sp, env, env_active, new_trips


def control(
    sample: RigSample,
    params: CoreParams,
    state: CoreState,
    r: Request,
    err: float,
    env: sf.EnvelopeState,
    switched: bool,
) -> tuple[float, PIState, PIComponents, int, int]:
    """Stage 5: the current the mode's controller asks for, A, its PI state and components, and the
    identification experiment's counters."""
    dt, lim = params.period_s, params.safety
    I_lim, I_cool = lim.I_limit_A, lim.I_cool_limit_A
    pi_st = state.pi
    if switched or env.cut:
        pi_st = bumpless(
            r.gains,
            state.u_prev_A if not env.cut else 0.0,
            err,
            r.ff,
            -I_cool,
            I_lim,
            flux_error_W=r.eQ,
            flux_gains=r.fg,
        )
    ident_k, ident_guard = 0, 0
    if params.mode is Mode.IDLE:
        stepA = params.idle_ramp_A_per_s * dt
        u_req = (
            min(max(0.0, state.u_prev_A - stepA), state.u_prev_A + stepA)
            if math.isfinite(state.u_prev_A)
            else 0.0
        )
        comps = PIComponents(0.0, 0.0, 0.0, u_req, u_req, False)
    elif params.mode is Mode.IDENTIFY:
        plan = params.identify
        j = 0 if switched else state.ident_k
        guard = 0 if switched else state.ident_guard
        if j < plan.total:
            u_req, guarded = guarded_current(
                plan.current_at(j),
                sample.T_sensor_C,
                I_limit_A=I_lim,
                T_min_C=lim.T_min_C,
                T_max_C=lim.T_max_C,
                margin_C=plan.margin_C,
            )
            ident_k, ident_guard = j + 1, guard + int(guarded)
        else:  # done: hold 0 A until the mode changes (the count goes on: ident_k > total means done)
            u_req, ident_k, ident_guard = 0.0, j + 1, guard
        comps = PIComponents(0.0, 0.0, 0.0, u_req, u_req, False)
    elif r.hold_current:
        u_req = state.u_prev_A
        comps = PIComponents(0.0, pi_st.integral_A, 0.0, u_req, u_req, False)
    else:
        u_req, pi_st, comps = pi_step(
            r.gains, pi_st, err, r.ff, dt, -I_cool, I_lim, flux_error_W=r.eQ, flux_gains=r.fg
        )
    return u_req, pi_st, comps, ident_k, ident_guard


def limit(
    params: CoreParams,
    state: CoreState,
    e: Estimates,
    r: Request,
    err: float,
    u_req: float,
    env: sf.EnvelopeState,
    pi_st: PIState,
    Q_W: float,
) -> tuple[float, tuple[str, ...], PIState]:
    """Stage 6: the envelope on the current (:func:`telethermo.control.safety.limit_current`, slewed from
    the previous step's current while a peer trip is latched) of the controller's ``u_req`` (A), and the PI
    state: where the envelope overrode the controller, re-seeded bumpless at the limited current (no windup
    behind it). ``err``: the setpoint error, °C; ``Q_W``: the measured flux, W. Returns the current (A),
    the limits that acted, the PI state."""
    lim = params.safety
    current, cur_active = sf.limit_current(
        lim, env, u_req, e.s_hi, e.s_lo, state.u_prev_A, params.period_s, Q_W
    )
    if current != u_req:
        # the envelope overrode the controller: keep the integrator consistent (no windup behind it)
        I_lim, I_cool = lim.I_limit_A, lim.I_cool_limit_A
        pi_st = bumpless(r.gains, current, err, r.ff, -I_cool, I_lim, flux_error_W=r.eQ, flux_gains=r.fg)
    return current, cur_active, pi_st
