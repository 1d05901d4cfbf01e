"""The control core's parameters: :class:`CoreParams` (frozen, self-checking; defaults from
:mod:`telethermo.control.defaults`), the rendering settings and the feedback/phase enums."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum
from typing import Any, cast

from telethermo.control import safety as sf
from telethermo.control.contact import ContactParams
from telethermo.control.defaults import CORE
from telethermo.control.estimators import Estimator
from telethermo.control.later_phase import LaterPhase
from telethermo.control.material_stream import MaterialIdParams
from telethermo.control.pi import FluxPIGains, PIGains
from telethermo.control.rendering import contact_temperature, pad_preset_temperature
from telethermo.control.types import Mode, Role
from telethermo.control.virtual_finger import VF_AREA_M2, VirtualFinger, vf_model
from telethermo.ident.plan import IdentifyPlan


class Feedback(str, Enum):
    """What the PI compares with the setpoint."""

    ESTIMATE = "estimate"  # the own contact-side estimate (the pad surface the finger/object touches)
    MODEL = "model"  # the model's T_pred (guiatni eq. 34/35 taken literally)


class RenderPhase(str, Enum):
    """Where virtual rendering is."""

    PRESET = "preset"  # no contact: pad held at T_pad0 (eq. 7)
    CONTACT = "contact"  # contact detected: pad held at T_contact (eq. 1)


@dataclass(frozen=True, slots=True)
class RenderSettings:
    """What the master renders with no slave (yamamoto).

    Attributes:
        beta_object: relative effusivity of the virtual object (β = b/b_finger).
        T_object0_C: the virtual object's initial temperature, °C.
        beta_pad: the pad's effective β for this user (from :func:`calibrate_finger`).
        T_finger0_C: the finger's initial surface temperature, °C.
        hold_current_on_contact: calibration touch: on contact hold the current instead of
            switching the command (the pad responds naturally; see ``calibrate_finger``).
        settle_s: after the detected touch the current is held this long, s, while the filtered
            measurements catch up with the skin's natural jump (≈ 2 × the filter's group delay);
            then the PI resumes, bumpless, on T_contact.
        material: name, for the records.
        later: the later-phase model (:mod:`telethermo.control.later_phase`); None = eq. 1's T_contact
            for the whole touch (semi-infinite object).
    """

    beta_object: float
    T_object0_C: float
    beta_pad: float = 2.23
    T_finger0_C: float = 33.0
    hold_current_on_contact: bool = False
    settle_s: float = 0.1
    material: str = ""
    later: LaterPhase | None = None

    def __post_init__(self) -> None:
        for name in ("beta_object", "beta_pad"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"RenderSettings.{name}: expected a finite number > 0, got {v!r}")
        if not (isinstance(self.settle_s, (int, float)) and 0 <= self.settle_s <= 2.0):
            raise ValueError(f"RenderSettings.settle_s: expected a time in [0, 2] s, got {self.settle_s!r}")
        for name in ("T_object0_C", "T_finger0_C"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and -20 <= v <= 90):
                raise ValueError(f"RenderSettings.{name}: expected a temperature in [-20, 90] °C, got {v!r}")

    @property
    def T_pad0_C(self) -> float:
        """Pad pre-set temperature (eq. 7), °C."""
        return pad_preset_temperature(self.T_finger0_C, self.T_object0_C, self.beta_object, self.beta_pad)

    @property
    def T_contact_C(self) -> float:
        """Contact temperature to render (eq. 1 with relative effusivities), °C."""
        return contact_temperature(self.T_finger0_C, 1.0, self.T_object0_C, self.beta_object)


NO_GAINS = PIGains(0.0, 0.0)


def _finite_number(
    owner: str, name: str, v: Any, *, lo: float | None = None, hi: float | None = None, lo_open: bool = False
) -> None:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ValueError(f"{owner}.{name}: expected a finite number, got {v!r}")
    if lo is not None and (v <= lo if lo_open else v < lo):
        raise ValueError(f"{owner}.{name}: expected {'>' if lo_open else '>='} {lo}, got {v!r}")
    if hi is not None and v > hi:
        raise ValueError(f"{owner}.{name}: expected <= {hi}, got {v!r}")


@dataclass(frozen=True, slots=True)
class CoreParams:
    """Everything a controller is configured with. Frozen; validated on construction.

    Attributes:
        role: MASTER (display, estimates T_f, tracks T_o) or SLAVE (probe, estimates T_o, tracks T_f).
        mode: :class:`Mode`.
        period_s: control period, s.
        kp_A_per_C, ki_A_per_C_s: PI gains on the temperature error (A/°C, A/(°C·s)).
        kQ_A_per_W: heat-flux feed-forward gain, A/W: u_ff = -kQ·Q_peer (see module docstring).
        kpQ_A_per_W, kiQ_A_per_W_s: heat-flux tracking loop (0 = off): the pad's own flux Q is driven
            towards the mirror of the peer's, -Q_peer (telepresence), sharing the PI's integrator.
            On the master this makes the display a flux source (the finger feels the flux the
            object draws), the slave stays a temperature source (see docs/control.md).
        kQ_render_A_per_W: RENDER mode's disturbance feed-forward on the pad's own flux, A/W:
            u_ff = +kQ_render·Q (the finger draws heat out of the pad -> more current).
        estimator: :class:`Estimator` (FLUX default; MODEL = the paper's eq. 30/31).
        feedback: :class:`Feedback`: what the PI controls.
        R_sensor_K_per_W: thermal resistance of the heat-flux sensor, K/W (flux estimator).
        fused_weight: weight of the model estimate in FUSED.
        safety: :class:`telethermo.control.safety.SafetyLimits`.
        render: :class:`RenderSettings` (required in RENDER mode).
        contact: :class:`telethermo.control.contact.ContactParams`.
        idle_ramp_A_per_s: how fast IDLE brings the current to 0, A/s.
        identify: the identification experiment run in IDENTIFY mode
            (:class:`telethermo.ident.plan.IdentifyPlan`).
        echo_peer_when_free: (slave, telepresence) while no contact is detected, send back the
            peer's estimate instead of the own (an object estimate in air means nothing): the
            display then only mirrors the probe's flux, and the finger rests as in air.
        passive_bound: (master, telepresence) in contact, the target stays on the object's side of the
            finger's temperature when the touch began (no nearer the object than ``safety.neutral_C``): a
            passive object cannot push the skin past it; and it comes back at most ``RETURN_C`` (1.5 °C)
            from the furthest it went towards the object (:mod:`telethermo.control.passive_bound`).
        air_rendering: (master, telepresence) render *air* while the probe touches nothing (the
            peer's contact flag is False): no temperature tracking, the flux loop
            (``air_kpQ_A_per_W``, ``air_kiQ_A_per_W_s``) draws from the finger only what air would,
            ``G_air_W_per_K·(T_f − T_air_C)``, so the finger stays at its natural temperature; once the
            finger is lifted (own contact detector and the rig's flag both off after a touch) hold
            ``safety.neutral_C`` (no drift); before any finger the pad renders air too, i.e. rests at
            ambient. In contact the published law runs (track T_o, flux mirror).
        G_air_W_per_K: conductance of still air over the contact area (h·A = 15 W/(m²·K) · 15 × 15 mm), W/K.
        T_air_C: the air's temperature for air rendering, °C.
        material_id: (slave) material identification from each touch's first samples
            (:mod:`telethermo.control.material_stream`); None turns it off.
        link_loss_render_s: (master, telepresence) graceful link loss: when the slave is lost while the
            operator touches and it identified the material in this touch or the last, render that material
            locally for at most this long, s, before the ramp to neutral (0: ramp at once, as before;
            :mod:`telethermo.control.link_fallback`).
        osc_guard_C: (slave, telepresence) the oscillation guard's threshold, °C: when successive half-cycles
            of the finger estimate received (its 0.3-5 Hz band) peak at or above it in settled contact, they
            set the probe's kp in contact to a quarter; 0: off (:mod:`telethermo.control.osc_guard`).
        virtual_finger_b: (slave, telepresence; an experiment, 0 = off) in contact the probe's setpoint is a
            virtual finger of this effusivity, W·s^½/(m²·K), started at the master's finger estimate and
            losing the heat the probe's sensor measures (:mod:`telethermo.control.virtual_finger`).
    """

    role: Role
    mode: Mode = Mode.TELEPRESENCE
    period_s: float = CORE["period_s"]
    kp_A_per_C: float = CORE["kp_A_per_C"]
    ki_A_per_C_s: float = CORE["ki_A_per_C_s"]
    kQ_A_per_W: float = CORE["kQ_A_per_W"]
    kpQ_A_per_W: float = CORE["kpQ_A_per_W"]
    kiQ_A_per_W_s: float = CORE["kiQ_A_per_W_s"]
    kQ_render_A_per_W: float = CORE["kQ_render_A_per_W"]
    estimator: Estimator = Estimator.FLUX
    feedback: Feedback = Feedback.ESTIMATE
    R_sensor_K_per_W: float = CORE["R_sensor_K_per_W"]
    fused_weight: float = CORE["fused_weight"]
    safety: sf.SafetyLimits = field(default_factory=sf.SafetyLimits)
    render: RenderSettings | None = None
    contact: ContactParams = field(default_factory=ContactParams)
    idle_ramp_A_per_s: float = CORE["idle_ramp_A_per_s"]
    identify: IdentifyPlan = field(default_factory=IdentifyPlan)
    echo_peer_when_free: bool = False
    air_rendering: bool = False
    passive_bound: bool = False
    air_kpQ_A_per_W: float = CORE["air_kpQ_A_per_W"]
    air_kiQ_A_per_W_s: float = CORE["air_kiQ_A_per_W_s"]
    G_air_W_per_K: float = CORE["G_air_W_per_K"]
    T_air_C: float = CORE["T_air_C"]
    material_id: MaterialIdParams | None = field(default_factory=MaterialIdParams)
    link_loss_render_s: float = CORE["link_loss_render_s"]
    osc_guard_C: float = CORE["osc_guard_C"]
    virtual_finger_b: float = CORE["virtual_finger_b"]
    _gains: Any = field(default=None, init=False, repr=False, compare=False)
    _flux_gains: Any = field(default=None, init=False, repr=False, compare=False)
    _air_gains: Any = field(default=None, init=False, repr=False, compare=False)
    _vf: Any = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        o = "CoreParams"
        try:
            object.__setattr__(self, "role", Role(self.role))
            object.__setattr__(self, "mode", Mode(self.mode))
            object.__setattr__(self, "estimator", Estimator(self.estimator))
            object.__setattr__(self, "feedback", Feedback(self.feedback))
        except ValueError as exc:
            raise ValueError(f"{o}: {exc}") from exc
        _finite_number(o, "period_s", self.period_s, lo=0.0, hi=1.0, lo_open=True)
        _finite_number(o, "kp_A_per_C", self.kp_A_per_C, lo=0.0, hi=100.0)
        _finite_number(o, "ki_A_per_C_s", self.ki_A_per_C_s, lo=0.0, hi=1000.0)
        _finite_number(o, "kQ_A_per_W", self.kQ_A_per_W, lo=-100.0, hi=100.0)
        _finite_number(o, "kpQ_A_per_W", self.kpQ_A_per_W, lo=0.0, hi=100.0)
        _finite_number(o, "kQ_render_A_per_W", self.kQ_render_A_per_W, lo=-100.0, hi=100.0)
        _finite_number(o, "kiQ_A_per_W_s", self.kiQ_A_per_W_s, lo=0.0, hi=1000.0)
        _finite_number(o, "R_sensor_K_per_W", self.R_sensor_K_per_W, lo=0.0, hi=1000.0)
        _finite_number(o, "fused_weight", self.fused_weight, lo=0.0, hi=1.0)
        _finite_number(o, "idle_ramp_A_per_s", self.idle_ramp_A_per_s, lo=0.0, lo_open=True)
        _finite_number(o, "air_kpQ_A_per_W", self.air_kpQ_A_per_W, lo=0.0, hi=100.0)
        _finite_number(o, "air_kiQ_A_per_W_s", self.air_kiQ_A_per_W_s, lo=0.0, hi=1000.0)
        _finite_number(o, "G_air_W_per_K", self.G_air_W_per_K, lo=0.0, hi=1.0)
        _finite_number(o, "T_air_C", self.T_air_C, lo=-20.0, hi=60.0)
        _finite_number(o, "link_loss_render_s", self.link_loss_render_s, lo=0.0, hi=60.0)
        _finite_number(o, "osc_guard_C", self.osc_guard_C, lo=0.0, hi=10.0)
        _finite_number(o, "virtual_finger_b", self.virtual_finger_b, lo=0.0, hi=1.0e5)
        if not isinstance(self.passive_bound, bool):
            raise ValueError(f"{o}.passive_bound: expected True or False, got {self.passive_bound!r}")
        if not isinstance(self.air_rendering, bool):
            raise ValueError(f"{o}.air_rendering: expected True or False, got {self.air_rendering!r}")
        if not isinstance(self.identify, IdentifyPlan):
            raise ValueError(f"{o}.identify: expected an IdentifyPlan, got {type(self.identify).__name__}")
        if not isinstance(self.safety, sf.SafetyLimits):
            raise ValueError(f"{o}.safety: expected SafetyLimits, got {type(self.safety).__name__}")
        if self.mode is Mode.RENDER and self.render is None:
            raise ValueError(f"{o}.render: RENDER mode needs RenderSettings")
        if self.mode is Mode.RENDER and self.role is not Role.MASTER:
            raise ValueError(f"{o}.mode: RENDER runs on the master only")
        # built once: step() runs every SYNC
        object.__setattr__(self, "_gains", PIGains(self.kp_A_per_C, self.ki_A_per_C_s))
        fg = (
            None
            if (self.kpQ_A_per_W == 0.0 and self.kiQ_A_per_W_s == 0.0)
            else FluxPIGains(self.kpQ_A_per_W, self.kiQ_A_per_W_s)
        )
        object.__setattr__(self, "_flux_gains", fg)
        object.__setattr__(self, "_air_gains", FluxPIGains(self.air_kpQ_A_per_W, self.air_kiQ_A_per_W_s))
        if self.virtual_finger_b > 0 and self.role is Role.SLAVE:
            object.__setattr__(self, "_vf", vf_model(self.virtual_finger_b, VF_AREA_M2, self.period_s))

    @property
    def gains(self) -> PIGains:
        """Temperature PI gains."""
        return cast(PIGains, self._gains)

    @property
    def flux_gains(self) -> FluxPIGains | None:
        """Heat-flux loop gains (kp in A/W, ki in A/(W·s)), None when off."""
        return cast("FluxPIGains | None", self._flux_gains)

    @property
    def virtual_finger(self) -> VirtualFinger | None:
        """The probe's virtual finger (slave with ``virtual_finger_b`` > 0), None when off."""
        return cast("VirtualFinger | None", self._vf)


# ---------------------------------------------------------------------------------------------
# predictor cell: carries a stateful predictor through pure steps
