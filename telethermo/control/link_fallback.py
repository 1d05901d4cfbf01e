"""Graceful link loss (issue 15): the master renders the last identified material locally while the
slave is lost.

In telepresence the master tracks the slave's object estimate. When the slave is lost (peer not alive, or its
values invalid) the envelope ramps to neutral and cuts (DESIGN.md §6). If the operator is touching at that
moment (the master's contact, with the probe touching an object at the last values received) and the slave
identified the object's material in this touch or the previous one (:mod:`telethermo.control.material_stream`,
sent in its contact PDO), the master instead renders that material itself, as the render mode does (when the
slave abstained, code "unknown", only the effusivity and object temperature it fitted, never a class)
(yamamoto §III, benali-khoudja §4):

- eq. 1: T_contact = (T_f0 + β·T_o0)/(1 + β), with T_f0 the finger's temperature before the touch (the
  master's own estimate while the probe was in the air), β the identified relative effusivity and T_o0 the
  object's initial temperature the same identification fitted (sent with it). Without a T_o0 (or without
  T_f0), T_o0 is eq. 1 inverted from the object's surface temperature the slave sent last (its estimate,
  eq. 31: the contact face), T_o0 = T_s + (T_s − T_f0)/β: the render then starts at the temperature
  telepresence was showing. Either way the envelope's ramp limit carries the setpoint from telepresence's
  last value to the render, and its trip slew and lead bound (:mod:`telethermo.control.safety`) keep the pad
  surface within the ramp limit + 1 °C/s where the touch itself does not move faster (bench/stress_slew.py);
- then the later-phase model (:mod:`telethermo.control.later_phase`, the render default: the conduction model
  of a :data:`FALLBACK_THICKNESS_MM` block of the material, adiabatic back), driven by the flux the finger
  sends into the pad, from the instant of the loss;
- tracked by a temperature PI with telepresence's proportional gain and the render mode's integral gain
  (:func:`fallback_gains`; no flux terms: they need the peer). Measured by bench/link_loss_bench.py (mean skin
  error over five 20 mm objects): render gains 0.89 °C, telepresence gains 0.88 °C, this mix 0.72 °C.

This lasts at most ``render_s`` (CoreParams.link_loss_render_s; 0 disables) and while the finger stays on the
pad; then the envelope's peer trip takes over as before (ramp to neutral, cut, EMCY 0x8130). While the
fallback runs the envelope does not require the peer (no PEER_LOST trip), everything else of it applies. When
the link returns during the fallback, telepresence resumes (the core's source switch is bumpless; the
envelope's ramp limit carries the setpoint from the render to the peer's estimate).

Pure: :class:`LinkState` is an immutable value carried in the core's state; :func:`link_step` runs every
master telepresence step.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace
from typing import Any, cast

from telethermo.control.defaults import RENDER_GAINS
from telethermo.control.later_phase import (
    DEFAULT_LATER_MODEL,
    DEFAULT_THICKNESS_MM,
    LaterPhase,
    later_phase,
    later_setpoint,
    later_start,
)
from telethermo.control.material_stream import UNKNOWN_CODE
from telethermo.control.pi import PIGains
from telethermo.control.rendering import contact_temperature, load_render_table
from telethermo.control.types import PeerValues
from telethermo.control.virtual_object import VirtualObject, load_object_table

#: thickness of the object the fallback renders, mm (the slave does not measure it: a block)
FALLBACK_THICKNESS_MM = DEFAULT_THICKNESS_MM
#: the fallback's integral gain, A/(°C·s): the render mode's (telepresence's small one leaves the load to the
#: flux terms, which need the peer)
FALLBACK_KI_A_PER_C_S = RENDER_GAINS["ki_A_per_C_s"]
#: plausible range of the inverted object temperature, °C (the envelope clamps the setpoint anyway)
T_OBJECT_RANGE_C = (-20.0, 90.0)


@dataclass(frozen=True, slots=True)
class LinkState:
    """What the master remembers for a link loss (immutable).

    Attributes:
        touch: touches seen (rising edges of: the master's contact with the probe touching).
        touching: the previous step was a touch.
        T_finger0_C: the finger's temperature before the touch, °C (the master's estimate while the probe was
            in the air), NaN unknown.
        T_surface_C: the object's surface temperature last received in this touch (the slave's estimate), °C.
        code, beta: the last identified material (rendering-table code, 0 none; β = b/b_skin).
        T_object0_id_C: the object's initial temperature the slave's identification fitted, °C (the latest
            received; NaN none).
        id_touch: the touch during which that identification arrived (-2: never).
        peer_touch: the slave's touch counter last received.
        active: the fallback renders now. t_s: time since it started, s. spent: it ran out (or could not
            start) in this loss: neutral as before until the link returns.
        T_object0_C, T_contact_C: the fallback's eq. 1 values, °C. later: (LaterPhase, its state).
    """

    touch: int = 0
    touching: bool = False
    T_finger0_C: float = math.nan
    T_surface_C: float = math.nan
    code: int = 0
    beta: float = math.nan
    T_object0_id_C: float = math.nan
    id_touch: int = -2
    peer_touch: int = 0
    active: bool = False
    t_s: float = 0.0
    spent: bool = False
    T_object0_C: float = math.nan
    T_contact_C: float = math.nan
    later: Any = None


@dataclass(frozen=True, slots=True)
class LinkResult:
    """One step: the new state, the setpoint to render (°C; NaN: not rendering), and whether the fallback
    started in this very step (raise its EMCY once)."""

    state: LinkState
    setpoint_C: float
    started: bool = False

    @property
    def active(self) -> bool:
        return self.state.active


@functools.lru_cache(maxsize=32)
def fallback_later_phase(code: int, dt_s: float) -> LaterPhase:
    """The later-phase model the fallback renders material ``code`` with (the render default model of a
    :data:`FALLBACK_THICKNESS_MM` block; semi-infinite for a material the object table does not know, and for
    the slave's "unknown" (:data:`UNKNOWN_CODE`: it abstained, so no class's block is rendered, only the
    effusivity and object temperature it measured))."""
    if code == UNKNOWN_CODE:
        return later_phase("semi_infinite", None, dt_s)
    names = list(load_render_table())
    name = names[code - 1] if 1 <= code <= len(names) else ""
    try:
        load_object_table().get(name)
    except ValueError:
        return later_phase("semi_infinite", None, dt_s)
    return later_phase(DEFAULT_LATER_MODEL, VirtualObject(name, FALLBACK_THICKNESS_MM), dt_s)


def fallback_gains(kp_A_per_C: float) -> PIGains:
    """The fallback's PI: ``kp_A_per_C`` (telepresence's, A/°C) and :data:`FALLBACK_KI_A_PER_C_S`."""
    return PIGains(kp_A_per_C, FALLBACK_KI_A_PER_C_S)


def object_temperature(T_finger0_C: float, T_surface_C: float, beta: float) -> float:
    """Eq. 1 inverted: the object's initial temperature, °C, whose contact with a finger at ``T_finger0_C``
    gives the surface temperature ``T_surface_C`` (relative effusivity ``beta``); ``T_surface_C`` when the
    finger's temperature is unknown. Clamped to :data:`T_OBJECT_RANGE_C`."""
    if not math.isfinite(T_finger0_C):
        return T_surface_C
    T = T_surface_C + (T_surface_C - T_finger0_C) / beta
    return min(max(T, T_OBJECT_RANGE_C[0]), T_OBJECT_RANGE_C[1])


def _track(
    st: LinkState, peer: PeerValues | None, peer_usable: bool, contact: bool, est_C: float
) -> LinkState:
    """Follow the touch, the finger's temperature, the object's surface and the identification (link up)."""
    probe = peer.contact if peer is not None else None
    touching = contact and probe is not False
    touch = st.touch + (1 if touching and not st.touching else 0)
    T_f0, T_s, code, beta, id_touch, peer_touch = (
        st.T_finger0_C,
        st.T_surface_C,
        st.code,
        st.beta,
        st.id_touch,
        st.peer_touch,
    )
    T_o0 = st.T_object0_id_C
    if peer_usable:
        peer = cast(PeerValues, peer)  # usable: there is one
        T_o0 = peer.material_T_object0_C  # the latest (it may come a few cycles after the counter)
        if probe is False and math.isfinite(est_C):
            T_f0 = est_C  # the probe in the air: the master's estimate is the finger's own temperature
        T_s = peer.estimate_C if touching else math.nan
        if peer.material_touch != peer_touch:
            peer_touch = peer.material_touch
            b = peer.material_beta
            ok = peer.material_code > 0 and math.isfinite(b) and b > 0
            code, beta, id_touch = (peer.material_code, b, touch) if ok else (0, math.nan, -2)
    elif not touching:
        T_s = math.nan
    return replace(
        st,
        touch=touch,
        touching=touching,
        T_finger0_C=T_f0,
        T_surface_C=T_s,
        code=code,
        beta=beta,
        T_object0_id_C=T_o0,
        id_touch=id_touch,
        peer_touch=peer_touch,
    )


def _can_start(st: LinkState, render_s: float, peer_tripped: bool) -> bool:
    return (
        render_s > 0
        and not st.spent
        and not peer_tripped
        and st.touching
        and st.code > 0
        and st.id_touch >= st.touch - 1
        and math.isfinite(st.T_surface_C)
    )


def link_step(
    st: LinkState,
    peer: PeerValues | None,
    *,
    peer_usable: bool,
    contact: bool,
    est_C: float,
    q_in_W: float,
    T_surface_est_C: float,
    render_s: float,
    dt_s: float,
    peer_tripped: bool,
) -> LinkResult:
    """One master telepresence step.

    Args:
        st: the link state. peer: this step's :class:`~telethermo.control.types.PeerValues` (or None).
        peer_usable: the peer is alive and its values valid.
        contact: the master's contact (the finger on the pad).
        est_C: the master's estimate, °C. q_in_W: heat from the finger into the pad (−Q of its sensor), W.
        T_surface_est_C: the pad's surface estimate, °C (the conduction model's input).
        render_s: the longest fallback, s (0: never). dt_s: control period, s.
        peer_tripped: the envelope already holds a peer trip (a loss being handled as before: no fallback).
    """
    st = _track(st, peer, peer_usable, contact, est_C)
    if peer_usable:  # link up (or back): telepresence
        return LinkResult(replace(st, active=False, spent=False, t_s=0.0, later=None), math.nan)
    started = False
    if st.active:
        t = st.t_s + dt_s
        if t > render_s + 1e-12 or not st.touching:
            return LinkResult(replace(st, active=False, spent=True, later=None), math.nan)
        st = replace(st, t_s=t)
    elif _can_start(st, render_s, peer_tripped):
        T_f0 = st.T_finger0_C if math.isfinite(st.T_finger0_C) else st.T_surface_C
        T_o0 = st.T_object0_id_C
        if not (math.isfinite(T_o0) and math.isfinite(st.T_finger0_C)):
            T_o0 = object_temperature(st.T_finger0_C, st.T_surface_C, st.beta)
        T_o0 = min(max(T_o0, T_OBJECT_RANGE_C[0]), T_OBJECT_RANGE_C[1])
        T_c = contact_temperature(T_f0, 1.0, T_o0, st.beta)
        lp = fallback_later_phase(st.code, dt_s)
        st = replace(
            st, active=True, t_s=0.0, T_object0_C=T_o0, T_contact_C=T_c, later=(lp, later_start(lp, T_o0))
        )
        started = True
    else:
        return LinkResult(replace(st, spent=True), math.nan)
    lp, ls = st.later
    T_f0 = st.T_finger0_C if math.isfinite(st.T_finger0_C) else st.T_surface_C
    sp, ls = later_setpoint(lp, ls, st.T_contact_C, T_f0, st.T_object0_C, st.t_s, q_in_W, T_surface_est_C)
    return LinkResult(replace(st, later=(lp, ls)), sp, started)
