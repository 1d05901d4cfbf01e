"""The controller's parameters and the object dictionary: what a node shows, what an SDO write changes.

A node's controller runs with :class:`telethermo.control.core.CoreParams` built at run time by
``NodeParts.params_for(mode)`` (``telethermo.control.params.default_params`` for the role and mode,
the envelope at the rig's I_max). :class:`ParamBook` keeps what the operator changed by SDO on top of
those defaults, and builds the parameters of any mode from both; :func:`od_image` is what the node
writes into its object dictionary so that ``telethermo get`` shows the running controller.

The objects, their fields in CoreParams and their scopes are the rows of ``bus_config/partable.py``
(the table: ``docs/parameters.md``); this module reads them, and spells out only the few mappings that
are not "the object's value is the field's": the estimator's code,
``current_limit_A`` = ``safety.current_fraction`` x ``safety.I_max_A``, ``ramp_limit_C_per_s`` setting
both ramps (shown: the smaller), the identification amplitudes as the two ends of
``identify.amplitude_A``, the mode, and the rendering settings below.

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

from telethermo.bus_config.partable import (
    BY_NAME,
    ESTIMATOR_CODE,
    FRACTION_OF_I_MAX,
    GAINS as PER_MODE,
    HIGH_END,
    IDENTIFY,
    LOW_END,
    PARAMS,
    RENDER,
)
from telethermo.cia301 import ABORT_DEVICE_STATE, ABORT_MAX_BELOW_MIN, ABORT_RANGE, ABORT_TOO_HIGH
from telethermo.control.core import CoreParams, RenderSettings
from telethermo.control.estimators import Estimator
from telethermo.control.later_phase import later_from_key, later_key, later_od_values
from telethermo.control.types import Mode, Role

ESTIMATOR_CODES: dict[Estimator, int] = {Estimator.MODEL: 0, Estimator.FLUX: 1, Estimator.FUSED: 2}
CODE_ESTIMATORS = {v: k for k, v in ESTIMATOR_CODES.items()}
#: the gains with an object (0x2200..0x2202), kept per mode; the gains file marks them
GAIN_KEYS = tuple(p.name for p in PARAMS if p.scope == PER_MODE)
#: OD name -> SafetyLimits fields it sets (current_limit_A is a fraction of I_max: COMMON below)
SAFETY_KEYS: dict[str, tuple[str, ...]] = {
    p.name: tuple(f.removeprefix("safety.") for f in p.field)
    for p in PARAMS
    if p.field and p.field[0].startswith("safety.") and p.convert != FRACTION_OF_I_MAX
}
RENDER_KEYS = tuple(p.name for p in PARAMS if p.scope == RENDER)
LATER_KEYS = tuple(p.name for p in PARAMS if p.field == ("render.later",))  # on top of any render
_MATERIAL_FIELDS = ("render.material", "render.beta_object", "render.T_object0_C")
MATERIAL_KEYS = tuple(p.name for p in PARAMS if p.field and p.field[0] in _MATERIAL_FIELDS)
#: OD name -> IdentifyPlan field (the amplitudes are the two ends of ``amplitude_A``)
IDENT_KEYS: dict[str, str] = {
    p.name: p.field[0].removeprefix("identify.") for p in PARAMS if p.scope == IDENTIFY
}
#: every object a node mirrors and accepts writes of
PARAM_KEYS = tuple(p.name for p in PARAMS)
#: the objects a CiA 301 store saves (``mode`` is not: --mode decides it at boot)
STORED_KEYS = tuple(p.name for p in PARAMS if p.stored)


def _field_value(params: CoreParams, path: str) -> Any:
    obj: Any = params
    for part in path.split("."):
        obj = getattr(obj, part)
    return obj


class ParamBook:
    """The node's requested configuration: the power-on defaults plus every accepted SDO write.

    Args:
        role: the node's role.
        params_for: ``(mode, render) -> CoreParams``, the defaults (ValueError for a mode the node
            cannot run).
        has_model: a TEM model is loaded (the MODEL and FUSED estimators need one).
        table: the rendering table (material -> β), in file order (material_code k = k-th entry).
        od_material: the OD's power-on material (material_code, material_beta, object_T0_C) used
            when no render script gives one.
        script_first: the render script's first settings (a render scene), or None.
    """

    def __init__(
        self,
        role: Role,
        params_for: Callable[..., CoreParams],
        *,
        has_model: bool,
        table: dict[str, float],
        od_material: tuple[int, float, float],
        script_first: RenderSettings | None = None,
        mode: Mode = Mode.TELEPRESENCE,
        peer_miss_limit: int = 10,
    ) -> None:
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
        """finger_T0_C written by the operator
        (on a script: until its thermometer measures the next touch)."""
        self.later: dict[str, float] = {}
        """later_model, object_thickness_mm, object_back written by the operator
        (telethermo.control.later_phase)."""
        self._later_built: dict[tuple, Any] = {}
        if script_first is not None:
            self.render = script_first
        else:
            code, beta, T0 = od_material
            name = self._code_name(code)
            self.render = RenderSettings(
                beta_object=self.table[name] if name else float(beta),
                T_object0_C=float(T0),
                material=name or "custom",
            )
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

    def check(
        self, key: str, value: Any, *, current_limit_of: Callable[[], float] | None = None
    ) -> int | None:
        """The SDO abort code that refuses writing ``value`` to ``key`` now, or None to accept it."""
        if key == "mode":
            try:
                mode = Mode(int(value))
            except ValueError:
                return ABORT_RANGE
            if mode is Mode.RENDER and self.role is not Role.MASTER:
                return ABORT_DEVICE_STATE  # virtual rendering is the display's job
        if key == "estimator":
            est = CODE_ESTIMATORS.get(int(value))
            if est is None:
                return ABORT_RANGE
            if est is not Estimator.FLUX and not self.has_model:
                return ABORT_DEVICE_STATE  # no TEM model loaded: T_pred cannot be computed
        if key in IDENT_KEYS and self.mode is Mode.IDENTIFY:
            return ABORT_DEVICE_STATE  # the experiment's plan is fixed while it runs
        if BY_NAME[key].convert in (LOW_END, HIGH_END):
            lo, hi = self.params().identify.amplitude_A
            lo, hi = (float(value), hi) if BY_NAME[key].convert == LOW_END else (lo, float(value))
            if lo > hi:
                return ABORT_MAX_BELOW_MIN
        if key == "material_code" and int(value) and self._code_name(int(value)) is None:
            return ABORT_TOO_HIGH if int(value) > len(self.table) else ABORT_RANGE
        trial = self.copy()
        try:
            trial.apply(key, value)
            trial.params()
            if key in RENDER_KEYS:
                trial.render_settings()  # valid for a later RENDER too (RenderSettings checks its ranges)
        except ValueError:
            return ABORT_DEVICE_STATE if key == "mode" else ABORT_RANGE
        return None

    def apply(self, key: str, value: Any) -> None:
        """Record an accepted write (the controller takes it at its next SYNC). ValueError if invalid."""
        p = BY_NAME[key]
        if p.scope == PER_MODE:
            self.gains.setdefault(self.mode, {})[p.field[0]] = float(value)
        elif key == "mode":
            self.mode = Mode(int(value))
        elif key == "peer_pdo_miss_limit":
            self.peer_miss_limit = int(value)
        elif p.scope == RENDER:
            self._apply_render(key, value)
        elif p.scope == IDENTIFY:
            f = IDENT_KEYS[key]
            if p.convert in (LOW_END, HIGH_END):
                lo, hi = self.identify.get(f, self.params_for(Mode.IDENTIFY).identify.amplitude_A)
                value = (float(value), hi) if p.convert == LOW_END else (lo, float(value))
            else:
                value = int(value)
            self.identify[f] = value
        elif p.convert == FRACTION_OF_I_MAX:
            self.safety[p.field[0].removeprefix("safety.")] = float(value) / self.params().safety.I_max_A
        elif key in SAFETY_KEYS:
            for f in SAFETY_KEYS[key]:
                self.safety[f] = float(value)
        elif p.convert == ESTIMATOR_CODE:
            est = CODE_ESTIMATORS.get(int(value))
            if est is None:
                raise ValueError(f"estimator code {value}: expected 0, 1 or 2")
            self.common[p.field[0]] = est
        else:  # a CoreParams field of every mode
            self.common[p.field[0]] = float(value) if p.is_real else int(value)
        self.version += 1

    def _apply_render(self, key: str, value: Any) -> None:
        if key in MATERIAL_KEYS:
            self.scripted = False
            r = self.render
            if key == "material_code":
                code = int(value)
                name = self._code_name(code)
                if code and name is None:
                    raise ValueError(
                        f"material_code {code}: the rendering table has {len(self.table)} entries"
                    )
                self.render = (
                    dataclasses.replace(r, beta_object=self.table[name], material=name)
                    if name
                    else dataclasses.replace(r, material="custom")
                )
            elif key == "material_beta":
                self.render = dataclasses.replace(r, beta_object=float(value), material="custom")
            else:
                self.render = dataclasses.replace(r, T_object0_C=float(value))
        elif key == "pad_beta":
            self.beta_pad = float(value)
        elif key == "finger_T0_C":
            self.finger_T0_C = float(value)
        elif key in LATER_KEYS:
            self.later[key] = float(value)
        else:
            raise KeyError(key)


def od_image(
    params: CoreParams, render: RenderSettings | None, *, material_code: int, peer_miss_limit: int
) -> dict[str, Any]:
    """Object name -> value for every parameter object: the truth about ``params`` (and ``render``,
    the settings rendered or to be rendered)."""
    img: dict[str, Any] = {}
    later = later_od_values(render.later) if render is not None else {}
    for p in PARAMS:
        if p.scope == RENDER:
            if render is None:
                continue
            f = p.field[0].removeprefix("render.")
            img[p.name] = (
                material_code if f == "material" else later[p.name] if f == "later" else getattr(render, f)
            )
            continue
        if p.name == "peer_pdo_miss_limit":  # the peer link's, not the control core's
            img[p.name] = peer_miss_limit
            continue
        v = [_field_value(params, f) for f in p.field]
        if p.convert == ESTIMATOR_CODE:
            img[p.name] = ESTIMATOR_CODES[v[0]]
        elif p.convert == FRACTION_OF_I_MAX:
            img[p.name] = params.safety.I_limit_A
        elif p.convert in (LOW_END, HIGH_END):
            img[p.name] = v[0][0 if p.convert == LOW_END else 1]
        else:
            img[p.name] = min(v) if p.is_real else int(v[0])
    return img
