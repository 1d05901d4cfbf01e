"""The controller's parameters and the object dictionary: what a node shows, what an SDO write changes.

A node's controller runs with :class:`telethermo.control.core.CoreParams` built at run time by
``NodeParts.params_for(mode)`` (``telethermo.control.params.default_params`` for the role and mode,
the envelope at the rig's I_max). :class:`ParamBook` keeps what the operator changed by SDO on top of
those defaults, and builds the parameters of any mode from both; :func:`od_image` is what the node
writes into its object dictionary so that ``telethermo get`` shows the running controller:

| object | CoreParams | scope |
|---|---|---|
| kp_A_per_C, ki_A_per_C_s, kQ_A_per_W (0x2200..0x2202) | the same fields | per mode (each mode has its own gains) |
| estimator (0x2203): 0 model, 1 flux, 2 fused | ``estimator`` | all modes |
| R_sensor_C_per_W (0x2309) | ``R_sensor_K_per_W`` | all modes |
| T_min_C, T_max_C, hot_threshold_C, hot_time_limit_s, sink_trip_C, neutral_C, mismatch_limit_C (0x24xx) | ``safety.T_min_C``, ``T_max_C``, ``hot_C``, ``hot_time_limit_s``, ``sink_trip_C``, ``neutral_C``, ``mismatch_C`` | all modes |
| ramp_limit_C_per_s (0x2402) | ``safety.ramp_up_C_per_s`` and ``ramp_down_C_per_s`` (shown: the smaller) | all modes |
| current_limit_A (0x2405) | ``safety.current_fraction`` × ``safety.I_max_A`` | all modes |
| mode (0x2500) | ``mode`` | |
| link_loss_render_s (0x2618) | ``link_loss_render_s`` (graceful link loss, :mod:`telethermo.control.link_fallback`) | all modes (acts in master telepresence) |
| material_code, material_beta, object_T0_C, finger_T0_C, pad_beta (0x2600..0x2604) | ``render`` (:class:`RenderSettings`) | RENDER |
| later_model, object_thickness_mm, object_back (0x2605..0x2607) | ``render.later`` (:mod:`telethermo.control.later_phase`) | RENDER |
| ident_seed, ident_rest_samples, ident_train_samples, ident_validation_samples, ident_amplitude_min_A, ident_amplitude_max_A, ident_hold_samples (0x2800..0x2806) | ``identify`` (:class:`~telethermo.ident.plan.IdentifyPlan`) | IDENTIFY |

Rendering: ``material_code`` 0 is a custom material (β = ``material_beta``), k >= 1 the k-th entry of
the rendering table (``telethermo/data/render_materials.toml``, in file order); writing a code sets
``material_beta`` to the table's β, writing ``material_beta`` sets the code to 0. On a render scene the
node follows the scene's :class:`~telethermo.offline.render_script.RenderScript` (per-touch material,
finger thermometer) and the OD shows the settings in force; once the operator writes a material
(``material_code``, ``material_beta`` or ``object_T0_C``), the written settings replace the script's.
A written ``pad_beta`` (the user's calibration) or ``finger_T0_C`` applies on top of the script's
touches from then on (the operator's value wins over the script's finger thermometer).
"""
from __future__ import annotations

import dataclasses
from typing import Any, Callable

from telethermo.cia301 import ABORT_DEVICE_STATE, ABORT_MAX_BELOW_MIN, ABORT_RANGE, ABORT_TOO_HIGH
from telethermo.control.core import CoreParams, RenderSettings
from telethermo.control.estimators import Estimator
from telethermo.control.gain_fields import SDO_GAIN_FIELDS
from telethermo.control.later_phase import later_from_key, later_key, later_od_values
from telethermo.control.types import Mode, Role

GAIN_KEYS = SDO_GAIN_FIELDS   # the gains with an object (0x2200..0x2202); the gains file marks them
ESTIMATOR_CODES: dict[Estimator, int] = {Estimator.MODEL: 0, Estimator.FLUX: 1, Estimator.FUSED: 2}
CODE_ESTIMATORS = {v: k for k, v in ESTIMATOR_CODES.items()}
#: OD name -> SafetyLimits fields it sets (current_limit_A is special: fraction of I_max)
SAFETY_KEYS: dict[str, tuple[str, ...]] = {
    "T_min_C": ("T_min_C",), "T_max_C": ("T_max_C",), "ramp_limit_C_per_s": ("ramp_up_C_per_s", "ramp_down_C_per_s"),
    "hot_threshold_C": ("hot_C",), "hot_time_limit_s": ("hot_time_limit_s",), "sink_trip_C": ("sink_trip_C",),
    "neutral_C": ("neutral_C",), "mismatch_limit_C": ("mismatch_C",),
}
LATER_KEYS = ("later_model", "object_thickness_mm", "object_back")   # 0x2605..0x2607, on top of any render
RENDER_KEYS = ("material_code", "material_beta", "object_T0_C", "finger_T0_C", "pad_beta") + LATER_KEYS
MATERIAL_KEYS = ("material_code", "material_beta", "object_T0_C")
OTHER_KEYS = ("estimator", "R_sensor_C_per_W", "current_limit_A", "peer_pdo_miss_limit", "mode", "link_loss_render_s")
#: OD name -> IdentifyPlan field (the amplitudes are the two ends of ``amplitude_A``)
IDENT_KEYS: dict[str, str] = {
    "ident_seed": "seed", "ident_rest_samples": "rest_samples", "ident_train_samples": "train_samples",
    "ident_validation_samples": "validation_samples", "ident_amplitude_min_A": "amplitude_A",
    "ident_amplitude_max_A": "amplitude_A", "ident_hold_samples": "hold_samples",
}
#: every object a node mirrors and accepts writes of
PARAM_KEYS = GAIN_KEYS + tuple(SAFETY_KEYS) + RENDER_KEYS + OTHER_KEYS + tuple(IDENT_KEYS)


class ParamBook:
    """The node's requested configuration: the power-on defaults plus every accepted SDO write.

    Args:
        role: the node's role.
        params_for: ``(mode, render) -> CoreParams``, the defaults (ValueError for a mode the node cannot run).
        has_model: a TEM model is loaded (the MODEL and FUSED estimators need one).
        table: the rendering table (material -> β), in file order (material_code k = k-th entry).
        od_material: the OD's power-on material (material_code, material_beta, object_T0_C) used
            when no render script gives one.
        script_first: the render script's first settings (a render scene), or None.
    """

    def __init__(self, role: Role, params_for: Callable[..., CoreParams], *, has_model: bool,
                 table: dict[str, float], od_material: tuple[int, float, float],
                 script_first: RenderSettings | None = None, mode: Mode = Mode.TELEPRESENCE,
                 peer_miss_limit: int = 10) -> None:
        self.role = role
        self.params_for = params_for
        self.has_model = has_model
        self.table = dict(table)
        self.codes = {name: k for k, name in enumerate(self.table, start=1)}
        self.mode = Mode(mode)
        self.gains: dict[Mode, dict[str, float]] = {}
        self.common: dict[str, Any] = {}
        self.identify: dict[str, Any] = {}
        """IdentifyPlan fields written by the operator."""
        self.safety: dict[str, float] = {}
        self.peer_miss_limit = int(peer_miss_limit)
        self.scripted = script_first is not None
        """The render script chooses the material (until the operator writes one)."""
        self.beta_pad: float | None = None
        """pad_beta written by the operator (applies to the script's touches too)."""
        self.finger_T0_C: float | None = None
        """finger_T0_C written by the operator (on a script: until its thermometer measures the next touch)."""
        self.later: dict[str, float] = {}
        """later_model, object_thickness_mm, object_back written by the operator (telethermo.control.later_phase)."""
        self._later_built: dict[tuple, Any] = {}
        if script_first is not None:
            self.render = script_first
        else:
            code, beta, T0 = od_material
            name = self._code_name(code)
            self.render = RenderSettings(beta_object=self.table[name] if name else float(beta), T_object0_C=float(T0),
                                         material=name or "custom")
        self.version = 0

    # ------------------------------------------------------------------ building parameters
    def _code_name(self, code: int) -> str | None:
        return next((n for n, k in self.codes.items() if k == code), None) if code else None

    def params(self, mode: Mode | None = None, render: RenderSettings | None = None) -> CoreParams:
        """CoreParams of ``mode`` (default: the requested mode): defaults + what was written.

        ``render``: the render settings in force (default: :attr:`render` with the written pad β and
        finger temperature). Raises ValueError if the combination is invalid.
        """
        mode = self.mode if mode is None else Mode(mode)
        rs = self.render_settings() if render is None else render
        p = self.params_for(mode, render=rs if mode is Mode.RENDER else None)
        kw: dict[str, Any] = dict(self.common)
        kw.update(self.gains.get(mode, {}))
        if self.safety:
            kw["safety"] = dataclasses.replace(p.safety, **self.safety)
        if self.identify:
            kw["identify"] = dataclasses.replace(p.identify, **self.identify)
        return dataclasses.replace(p, **kw) if kw else p

    def render_settings(self) -> RenderSettings:
        """The settings given by the OD (not the script's) with the written pad β and finger temperature."""
        return self.overlay(self.render)

    def overlay(self, rs: RenderSettings) -> RenderSettings:
        """``rs`` with the operator's pad β and finger temperature (the same object if nothing changes)."""
        kw = {}
        if self.beta_pad is not None and rs.beta_pad != self.beta_pad:
            kw["beta_pad"] = self.beta_pad
        if self.finger_T0_C is not None and rs.T_finger0_C != self.finger_T0_C:
            kw["T_finger0_C"] = self.finger_T0_C
        if self.later:
            key = later_key(rs.later, rs.material, self.later)
            if key not in self._later_built:
                self._later_built[key] = later_from_key(key, self.params_for(Mode.IDLE).period_s)
            if self._later_built[key] is not rs.later:
                kw["later"] = self._later_built[key]
        return dataclasses.replace(rs, **kw) if kw else rs

    def material_code(self, rs: RenderSettings) -> int:
        """material_code of render settings: the table position of its material, 0 for a custom one."""
        return self.codes.get(rs.material, 0)

    # ------------------------------------------------------------------ writes
    def copy(self) -> "ParamBook":
        new = object.__new__(ParamBook)
        new.__dict__.update(self.__dict__)
        new.gains = {m: dict(g) for m, g in self.gains.items()}
        new.common, new.safety, new.identify = dict(self.common), dict(self.safety), dict(self.identify)
        new.later = dict(self.later)
        return new

    def check(self, key: str, value: Any, *, current_limit_of: Callable[[], float] | None = None) -> int | None:
        """The SDO abort code that refuses writing ``value`` to ``key`` now, or None to accept it."""
        if key == "mode":
            try:
                mode = Mode(int(value))
            except ValueError:
                return ABORT_RANGE
            if mode is Mode.RENDER and self.role is not Role.MASTER:
                return ABORT_DEVICE_STATE   # virtual rendering is the display's job
        if key == "estimator":
            est = CODE_ESTIMATORS.get(int(value))
            if est is None:
                return ABORT_RANGE
            if est is not Estimator.FLUX and not self.has_model:
                return ABORT_DEVICE_STATE   # no TEM model loaded: T_pred cannot be computed
        if key in IDENT_KEYS and self.mode is Mode.IDENTIFY:
            return ABORT_DEVICE_STATE   # the experiment's plan is fixed while it runs
        if key in ("ident_amplitude_min_A", "ident_amplitude_max_A"):
            lo, hi = self.params().identify.amplitude_A
            lo, hi = (float(value), hi) if key.endswith("min_A") else (lo, float(value))
            if lo > hi:
                return ABORT_MAX_BELOW_MIN
        if key == "material_code" and int(value) and self._code_name(int(value)) is None:
            return ABORT_TOO_HIGH if int(value) > len(self.table) else ABORT_RANGE
        trial = self.copy()
        try:
            trial.apply(key, value)
            trial.params()
            if key in RENDER_KEYS:
                trial.render_settings()   # valid for a later RENDER too (RenderSettings checks its ranges)
        except ValueError:
            return ABORT_DEVICE_STATE if key == "mode" else ABORT_RANGE
        return None

    def apply(self, key: str, value: Any) -> None:
        """Record an accepted write (the controller takes it at its next SYNC). ValueError if invalid."""
        if key in GAIN_KEYS:
            self.gains.setdefault(self.mode, {})[key] = float(value)
        elif key == "estimator":
            est = CODE_ESTIMATORS.get(int(value))
            if est is None:
                raise ValueError(f"estimator code {value}: expected 0, 1 or 2")
            self.common["estimator"] = est
        elif key == "R_sensor_C_per_W":
            self.common["R_sensor_K_per_W"] = float(value)
        elif key == "link_loss_render_s":
            self.common["link_loss_render_s"] = float(value)
        elif key in SAFETY_KEYS:
            for f in SAFETY_KEYS[key]:
                self.safety[f] = float(value)
        elif key == "current_limit_A":
            i_max = self.params().safety.I_max_A
            self.safety["current_fraction"] = float(value) / i_max
        elif key == "mode":
            self.mode = Mode(int(value))
        elif key == "peer_pdo_miss_limit":
            self.peer_miss_limit = int(value)
        elif key in MATERIAL_KEYS:
            self.scripted = False
            r = self.render
            if key == "material_code":
                code = int(value)
                name = self._code_name(code)
                if code and name is None:
                    raise ValueError(f"material_code {code}: the rendering table has {len(self.table)} entries")
                self.render = dataclasses.replace(r, beta_object=self.table[name], material=name) if name else \
                    dataclasses.replace(r, material="custom")
            elif key == "material_beta":
                self.render = dataclasses.replace(r, beta_object=float(value), material="custom")
            else:
                self.render = dataclasses.replace(r, T_object0_C=float(value))
        elif key in IDENT_KEYS:
            f = IDENT_KEYS[key]
            if f == "amplitude_A":
                lo, hi = self.identify.get(f, self.params_for(Mode.IDENTIFY).identify.amplitude_A)
                value = (float(value), hi) if key.endswith("min_A") else (lo, float(value))
            else:
                value = int(value)
            self.identify[f] = value
        elif key == "pad_beta":
            self.beta_pad = float(value)
        elif key == "finger_T0_C":
            self.finger_T0_C = float(value)
        elif key in LATER_KEYS:
            self.later[key] = float(value)
        else:
            raise KeyError(key)
        self.version += 1


def od_image(params: CoreParams, render: RenderSettings | None, *, material_code: int,
             peer_miss_limit: int) -> dict[str, Any]:
    """Object name -> value for every parameter object: the truth about ``params`` (and ``render``,
    the settings rendered or to be rendered)."""
    s = params.safety
    img: dict[str, Any] = {k: getattr(params, k) for k in GAIN_KEYS}
    img["estimator"] = ESTIMATOR_CODES[params.estimator]
    img["R_sensor_C_per_W"] = params.R_sensor_K_per_W
    img["link_loss_render_s"] = params.link_loss_render_s
    for key, fields in SAFETY_KEYS.items():
        img[key] = min(getattr(s, f) for f in fields)
    img["current_limit_A"] = s.I_limit_A
    img["peer_pdo_miss_limit"] = peer_miss_limit
    img["mode"] = int(params.mode)
    plan = params.identify
    img.update(ident_seed=plan.seed, ident_rest_samples=plan.rest_samples, ident_train_samples=plan.train_samples,
               ident_validation_samples=plan.validation_samples, ident_amplitude_min_A=plan.amplitude_A[0],
               ident_amplitude_max_A=plan.amplitude_A[1], ident_hold_samples=plan.hold_samples)
    if render is not None:
        img.update(material_code=material_code, material_beta=render.beta_object, object_T0_C=render.T_object0_C,
                   finger_T0_C=render.T_finger0_C, pad_beta=render.beta_pad, **later_od_values(render.later))
    return img

