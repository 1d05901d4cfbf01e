"""The script of a virtual-rendering session: which material each touch renders, and when.

Shared by the offline runner and the master node so both paths render identically:

    script = RenderScript(scene, beta_pad=2.23)
    for each cycle:
        settings = script.settings_at(sample.t_s, period_s, finger_skin_C)   # RenderSettings
        params = dataclasses.replace(base, mode=Mode.RENDER, render=settings)

The next touch's material is selected once the previous touch has ended. With ``finger_thermometer``
the finger's skin temperature is read ``thermometer_lead_s`` before each touch (yamamoto's radiation
thermometer; ``finger_skin_C`` is called then, on a simulated rig the skin's truth) and the touch's
T_finger0, T_pad0 (eq. 7) and T_contact (eq. 1) are updated from it.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Callable

from telethermo.control.core import RenderSettings
from telethermo.control.later_phase import DEFAULT_LATER_MODEL, LaterModel, later_phase
from telethermo.control.virtual_object import VirtualObject, load_object_table
from telethermo.control.rendering import load_render_table


def _object_beta(sc, name: str, spec, table: dict[str, float], objects) -> float:
    """β of a rendered object: the rendering table's by the touch's name, then by the object's material,
    then b/b_finger from the object table (telethermo/data/render_objects.toml)."""
    for key in (name, getattr(spec, "material", None)):
        if key in table:
            return table[key]
    try:
        return objects.beta(getattr(spec, "material", None) or name)
    except ValueError:
        raise ValueError(
            f"scene {sc.name}: render material {name!r} not in the rendering table "
            f"(known: {', '.join(sorted(table))}) nor in the object table"
        ) from None


def render_touches(
    sc,
    table: dict[str, float] | None = None,
    *,
    beta_pad: float = 2.23,
    T_finger0_C: float = 34.0,
    later_model: str = DEFAULT_LATER_MODEL.value,
    period_s: float | None = None,
) -> list[dict[str, Any]]:
    """Render settings of each touch of a virtual scene (β from the rendering table; ``later_model``:
    the later-phase model, built from the scene object's material, thickness and back)."""
    table = table or load_render_table()
    objects = load_object_table()
    out = []
    for t in sc.master_contacts:
        if t.render is None:
            continue
        spec = sc.objects.get(t.render)
        beta = _object_beta(sc, t.render, spec, table, objects)
        T_o = float(spec.T0_C) if spec is not None else float(sc.ambient_C)
        obj = VirtualObject(
            spec.material if spec is not None else t.render,
            spec.thickness_m * 1e3 if spec is not None else 20.0,
            spec.back if spec is not None else "adiabatic",
            T_ambient_C=float(sc.ambient_C),
        )
        try:
            later = later_phase(later_model, obj, period_s or sc.period_s, objects=objects)
        except ValueError:  # a material the object table does not know: eq. 1 for the whole touch
            later = later_phase(LaterModel.SEMI_INFINITE, obj, period_s or sc.period_s)
        rs = RenderSettings(
            beta_object=beta,
            T_object0_C=T_o,
            beta_pad=beta_pad,
            T_finger0_C=T_finger0_C,
            material=t.render,
            later=later,
        )
        out.append(
            {
                "material": t.render,
                "beta": beta,
                "t_on_s": t.start_s,
                "t_off_s": t.end_s,
                "thickness_mm": obj.thickness_mm,
                "back": obj.back,
                "later_model": later.model.value,
                "T_contact_C": rs.T_contact_C,
                "T_pad0_C": rs.T_pad0_C,
                "T_finger0_C": T_finger0_C,
                "T_object0_C": T_o,
                "settings": rs,
            }
        )
    return out


class RenderScript:
    """Per-touch render settings of a virtual scene over time (see module docstring)."""

    def __init__(
        self,
        sc,
        *,
        beta_pad: float = 2.23,
        T_finger0_C: float = 34.0,
        finger_thermometer: bool = True,
        thermometer_lead_s: float = 1.0,
        calibration_presets_C: list[float] | None = None,
        table: dict[str, float] | None = None,
        later_model: str = DEFAULT_LATER_MODEL.value,
    ) -> None:
        self.touches = render_touches(
            sc, table, beta_pad=beta_pad, T_finger0_C=T_finger0_C, later_model=later_model
        )
        if not self.touches:
            raise ValueError(
                f"scene {getattr(sc, 'name', sc)}: no master contact with a 'render' material: "
                "nothing to render"
            )
        if calibration_presets_C is not None:
            if len(calibration_presets_C) < len(self.touches):
                raise ValueError(
                    f"calibration_presets_C: expected {len(self.touches)} pre-sets (one per touch of "
                    f"{sc.name}), got {len(calibration_presets_C)}"
                )
            for t, T in zip(self.touches, calibration_presets_C):
                # rendering the pad's own material at T pre-sets the pad at T (eq. 7 with beta_obj = beta_pad)
                rs = RenderSettings(
                    beta_object=beta_pad,
                    T_object0_C=float(T),
                    beta_pad=beta_pad,
                    T_finger0_C=T_finger0_C,
                    hold_current_on_contact=True,
                    material="calibration",
                )
                t.update(
                    material="calibration",
                    beta=beta_pad,
                    T_object0_C=float(T),
                    settings=rs,
                    T_contact_C=rs.T_contact_C,
                    T_pad0_C=rs.T_pad0_C,
                )
        self.finger_thermometer = finger_thermometer
        self.thermometer_lead_s = float(thermometer_lead_s)
        self.idx = 0
        self._measured: set[int] = set()

    @property
    def first(self) -> RenderSettings:
        return self.touches[0]["settings"]

    def settings_at(
        self, t_s: float, period_s: float, finger_skin_C: Callable[[], float] | None = None
    ) -> RenderSettings:
        """The settings in force at ``t_s`` (advances the script; call once per cycle, in time order)."""
        touches = self.touches
        while self.idx + 1 < len(touches) and t_s >= touches[self.idx]["t_off_s"] + 0.5 * period_s:
            self.idx += 1
        i = self.idx
        if (
            self.finger_thermometer
            and finger_skin_C is not None
            and i not in self._measured
            and t_s >= touches[i]["t_on_s"] - self.thermometer_lead_s - 1e-9
        ):
            T_f0 = finger_skin_C()
            if math.isfinite(T_f0):
                rs = dataclasses.replace(touches[i]["settings"], T_finger0_C=T_f0)
                touches[i].update(
                    settings=rs, T_finger0_C=T_f0, T_contact_C=rs.T_contact_C, T_pad0_C=rs.T_pad0_C
                )
            self._measured.add(i)
        return touches[i]["settings"]

    def meta(self) -> list[dict[str, Any]]:
        """The touches as recorded in the recording's meta ``render`` (JSON-safe)."""
        return [{k: v for k, v in t.items() if k != "settings"} for t in self.touches]
