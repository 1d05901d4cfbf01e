"""The render mode's later-phase models against the simulator's direct touch: the figures of the rendering
benchmark (bench/rendering_bench.py writes them into rendering.json, with its plot).

Per virtual object (material, thickness; adiabatic back, at the 25 °C ambient): the master alone renders
one 10 s touch at 6 N (yamamoto eq. 7 pre-set, then eq. 1 at contact) with each later-phase model
(telethermo.control.later_phase: ``semi_infinite`` = the behaviour before issue 15, ``rc`` =
benali-khoudja §4, ``conduction`` = the few-cell model of the object), plus a null display that pre-sets
its pad as eq. 7 asks for the object and then holds its current through the touch (it ignores the
object). The figure is the RMS of the operator's skin temperature minus the same finger's skin when it
touches the same object directly (sim.build_reference), over 0-1 s (early_C) and 1-10 s (late_C) after
the touch.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from telethermo import sim
from telethermo.offline.render_script import RenderScript
from telethermo.offline.runner import run_offline_session

#: (label, sim material, thickness mm)
OBJECTS = (
    ("aluminium", "aluminium", 1.0),
    ("aluminium", "aluminium", 20.0),
    ("stainless_steel", "stainless_steel", 2.0),
    ("glass", "glass", 1.0),
    ("wood", "oak", 2.0),
    ("eps", "eps", 5.0),
)
QUICK_OBJECTS = OBJECTS[:2]
MODELS = ("semi_infinite", "rc", "conduction")
NULL = "null_hold_preset"
T_ON_S, TOUCH_S, FORCE_N, AMBIENT_C = 6.0, 10.0, 6.0, 25.0
EARLY_S, LATE_S = (0.0, 1.0), (1.0, 10.0)


def _scene(material: str, thickness_mm: float, render: bool) -> sim.Scene:
    raw: dict[str, Any] = {
        "scene": {
            "name": f"render_{material}_{thickness_mm:g}mm",
            "kind": "virtual",
            "ambient_C": AMBIENT_C,
            "duration_s": T_ON_S + TOUCH_S + 0.5,
            "period_s": 0.01,
        },
        "objects": {"obj": {"material": material, "thickness_mm": thickness_mm, "back": "adiabatic"}},
        "master": {"contacts": [{"start_s": T_ON_S, "end_s": T_ON_S + TOUCH_S + 0.5, "force_N": FORCE_N}]},
        "noise": {"seed": 5},
    }
    if render:
        raw["master"]["contacts"][0]["render"] = "obj"
    return sim.scene.parse_scene(raw, f"<rendering bench {material} {thickness_mm:g} mm>")


def _rms(t: np.ndarray, e: np.ndarray, window: tuple[float, float]) -> float:
    m = (t >= T_ON_S + window[0]) & (t < T_ON_S + window[1])
    return float(np.sqrt(np.mean(e[m] ** 2)))


def run_object(material: str, thickness_mm: float) -> dict[str, Any]:
    """Skin traces (t, direct touch, each model, null) of one object."""
    traces: dict[str, np.ndarray] = {}
    for model in MODELS:
        rec = run_offline_session(
            _scene(material, thickness_mm, True), render_options={"later_model": model}
        ).recording
        traces["t"], traces["direct"] = rec.col("t_s"), rec.col("ref_T_contact_C")
        traces[model] = rec.col("m_true_finger_C")
    # null: the pad pre-set as eq. 7 asks for this object, then its current held through the touch
    sc = _scene(material, thickness_mm, True)
    T_pad0 = RenderScript(sc).first.T_pad0_C
    rec = run_offline_session(sc, render_options={"calibration_presets_C": [T_pad0]}).recording
    traces[NULL] = rec.col("m_true_finger_C")
    return traces


def measure(quick: bool) -> tuple[list[dict[str, Any]], dict]:
    """The ``later_phase`` rows and the skin traces per (material label, thickness mm)."""
    rows, traces = [], {}
    for label, material, th in QUICK_OBJECTS if quick else OBJECTS:
        tr = run_object(material, th)
        traces[(label, th)] = tr
        for model in (*MODELS, NULL):
            e = tr[model] - tr["direct"]
            rows.append(
                {
                    "material": label,
                    "thickness_mm": th,
                    "model": model,
                    "early_C": round(_rms(tr["t"], e, EARLY_S), 4),
                    "late_C": round(_rms(tr["t"], e, LATE_S), 4),
                }
            )
    return rows, traces


def later_phase_figures(quick: bool) -> dict[str, Any]:
    """``{"later_phase": [{material, thickness_mm, model, early_C, late_C}, ...]}`` (JSON-ready)."""
    return {"later_phase": measure(quick)[0]}
