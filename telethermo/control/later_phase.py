"""The render mode's later phase: what the pad renders after the first instant of a touch.

Three models, chosen per render (``RenderSettings.later``):

- ``semi_infinite`` (yamamoto): eq. 1's T_contact for the whole touch (an object of infinite
  thickness: an aluminium foil and block feel the same);
- ``rc``: benali-khoudja's RC analog (:mod:`telethermo.control.later_rc`);
- ``conduction`` (the default of render sessions, :data:`DEFAULT_LATER_MODEL`): a few-cell conduction model of
  the object with its thickness and back (:mod:`telethermo.control.later_conduction`), driven by the flux the
  finger sends into the pad.

    lp = later_phase("conduction", VirtualObject("aluminium", 1.0), dt_s=0.01)
    st = later_start(lp, T_object0_C)                       # at the touch
    T, st = later_setpoint(lp, st, T_contact_C, T_finger0_C, T_object0_C, t_since_s, q_in_W, T_surface_C)
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import Any, cast

from telethermo.control.later_conduction import (
    ConductionModel,
    conduction_model,
    conduction_start,
    conduction_step,
)
from telethermo.control.later_rc import RcEntry, load_rc_table, rc_lookup, rc_temperature
from telethermo.control.virtual_object import ObjectTable, VirtualObject, load_object_table


class LaterModel(str, Enum):
    """Later-phase model of the render mode."""

    SEMI_INFINITE = "semi_infinite"
    RC = "rc"
    CONDUCTION = "conduction"


LATER_MODELS = tuple(m.value for m in LaterModel)
#: the render sessions' default (bench/rendering_bench.py: never worse than semi-infinite, best late phase)
DEFAULT_LATER_MODEL = LaterModel.CONDUCTION
#: OD codes (0x2605 later_model, 0x2607 object_back): position in these tuples
LATER_CODES = LATER_MODELS
BACK_CODES = ("adiabatic", "ambient")
#: the object of a render whose thickness nobody gave, mm (a block: semi-infinite over a touch for non-metals)
DEFAULT_THICKNESS_MM = 20.0


@dataclass(frozen=True, eq=False)
class LaterPhase:
    """A built later-phase model of one virtual object (immutable; its state is carried by the core).

    Attributes:
        model: :class:`LaterModel`. obj: the object.
        tau_s, final_fraction: the RC model's τ (s) and φ (RC only).
        conduction: the conduction model (CONDUCTION only).
    """

    model: LaterModel
    obj: VirtualObject | None = None
    tau_s: float = float("nan")
    final_fraction: float = 0.0
    conduction: ConductionModel | None = None


def later_phase(
    model: str | LaterModel,
    obj: VirtualObject | None,
    dt_s: float,
    *,
    load_g: float = 0.0,
    objects: ObjectTable | None = None,
    rc_table: list[RcEntry] | None = None,
) -> LaterPhase:
    """Build the later-phase model ``model`` of ``obj`` for a control period ``dt_s`` (s). The tables
    default to the shipped ones (telethermo/data/render_objects.toml, render_rc.toml)."""
    try:
        m = LaterModel(model)
    except ValueError:
        raise ValueError(
            f"later_phase: model: expected one of {', '.join(LATER_MODELS)}, got {model!r}"
        ) from None
    if m is LaterModel.SEMI_INFINITE:
        return LaterPhase(m, obj)
    if obj is None:
        raise ValueError(
            f"later_phase: the {m.value} model needs the virtual object (material, thickness, back)"
        )
    objects = objects or load_object_table()
    name = objects.canonical(obj.material)
    if m is LaterModel.RC:
        tau, phi = rc_lookup(
            rc_table if rc_table is not None else load_rc_table(), name, obj.thickness_mm, obj.back, load_g
        )
        return LaterPhase(m, obj, tau_s=tau, final_fraction=phi)
    return LaterPhase(m, obj, conduction=conduction_model(obj, objects.get(name), dt_s))


def later_start(lp: LaterPhase, T_object0_C: float) -> Any:
    """The model's state at the instant of a touch (None for the stateless models)."""
    if lp.model is LaterModel.CONDUCTION:
        return conduction_start(cast(ConductionModel, lp.conduction), T_object0_C)
    return None


def later_setpoint(
    lp: LaterPhase,
    state: Any,
    T_contact_C: float,
    T_finger0_C: float,
    T_object0_C: float,
    t_since_s: float,
    q_in_W: float,
    T_surface_C: float = float("nan"),
) -> tuple[float, Any]:
    """The temperature to render now, °C, and the model's next state.

    ``T_contact_C``: eq. 1; ``t_since_s``: time since the touch was detected, s; ``q_in_W``: heat flowing
    from the finger into the pad (= −Q_W of the pad's sensor), W, and ``T_surface_C`` the pad's surface
    estimate, °C (conduction model only).
    """
    if lp.model is LaterModel.RC:
        T_final = T_finger0_C + lp.final_fraction * (T_object0_C - T_finger0_C)
        return rc_temperature(T_contact_C, T_final, lp.tau_s, t_since_s), None
    if lp.model is LaterModel.CONDUCTION:
        state, corr = conduction_step(cast(ConductionModel, lp.conduction), state, q_in_W, T_surface_C)
        return T_contact_C + corr, state
    return T_contact_C, None


def later_od_values(lp: LaterPhase | None) -> dict[str, float | int]:
    """The OD image of a later phase: later_model code, object_thickness_mm, object_back code."""
    obj = lp.obj if lp is not None else None
    return {
        "later_model": LATER_CODES.index(lp.model.value) if lp is not None else 0,
        "object_thickness_mm": obj.thickness_mm if obj is not None else DEFAULT_THICKNESS_MM,
        "object_back": BACK_CODES.index(obj.back) if obj is not None else 0,
    }


def later_key(
    lp: LaterPhase | None, material: str, written: dict[str, float | int]
) -> tuple[str, str, float, str]:
    """(model, material, thickness_mm, back): ``lp``'s with the operator's OD writes (``written``: codes as
    in :func:`later_od_values`) on top; the key of :func:`later_from_key`. ValueError on a bad code."""
    cur = later_od_values(lp)
    cur.update(written)
    code, back = int(cur["later_model"]), int(cur["object_back"])
    if not (0 <= code < len(LATER_CODES) and 0 <= back < len(BACK_CODES)):
        raise ValueError(
            f"later phase: later_model {code} / object_back {back}: expected codes "
            f"0..{len(LATER_CODES) - 1} / 0..{len(BACK_CODES) - 1}"
        )
    return LATER_CODES[code], material, float(cur["object_thickness_mm"]), BACK_CODES[back]


def later_from_key(key: tuple[str, str, float, str], dt_s: float, T_ambient_C: float = 25.0) -> LaterPhase:
    """The later phase of a :func:`later_key` (ValueError for a material the tables do not know)."""
    model, material, thickness_mm, back = key
    return later_phase(model, VirtualObject(material, thickness_mm, back, T_ambient_C=T_ambient_C), dt_s)
