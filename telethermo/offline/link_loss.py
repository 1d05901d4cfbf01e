"""Graceful link loss (issue 15): the operator's skin while the slave is lost during a touch, against the
simulator's direct touch of the same object.

Per object (a 20 mm block at the 25 °C ambient, adiabatic back): telepresence with the default gains, the
operator's finger on the display all along (at its natural temperature), the probe touching the object from
``TOUCH_S[0]`` to ``TOUCH_S[1]`` at 8 N; the link is lost (offline runner's scripted peer loss) from
``LOSS_S`` on, 1 s after the probe touched (its identification needs the first 0.3 s), to the end. The same
scene runs three times:

- ``fallback``: the default ``link_loss_render_s`` (5 s): the master renders the identified material itself
  (telethermo.control.link_fallback);
- ``neutral_ramp``: ``link_loss_render_s = 0``, the behaviour before: ramp to neutral (32 °C), then cut;
- ``telepresence``: no loss (what the link would have given).

The figure is the RMS of the operator's skin minus the same finger's skin on the object touched directly
(sim.build_reference) over the fallback's window, ``LOSS_S`` to ``LOSS_S`` + 5 s:
``link_loss_fallback_error_C`` and ``link_loss_neutral_ramp_error_C`` are the means over the objects.

``python -m bench.link_loss_bench [--quick]`` prints the table; bench/rendering_bench.py writes the figures.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from telethermo import sim
from telethermo.control.params import default_params
from telethermo.control.types import Role
from telethermo.offline.runner import run_offline_session

#: (label, sim material)
OBJECTS = (
    ("aluminium", "aluminium"),
    ("carbon_steel", "carbon_steel"),
    ("glass", "glass"),
    ("oak", "oak"),
    ("eps", "eps"),
)
QUICK_OBJECTS = (("carbon_steel", "carbon_steel"), ("oak", "oak"))
TOUCH_S, LOSS_S, RENDER_S, FORCE_N, AMBIENT_C = (1.0, 8.5), 2.0, 5.0, 8.0, 25.0
RUNS = ("fallback", "neutral_ramp", "telepresence")


def _scene(material: str) -> sim.Scene:
    raw: dict[str, Any] = {
        "scene": {
            "name": f"link_loss_{material}",
            "kind": "telepresence",
            "ambient_C": AMBIENT_C,
            "duration_s": TOUCH_S[1] + 0.5,
            "period_s": 0.01,
        },
        "objects": {"obj": {"material": material, "thickness_mm": 20.0, "back": "adiabatic"}},
        "master": {
            "start": "finger",
            "contacts": [{"start_s": 0.0, "end_s": TOUCH_S[1] + 0.5, "force_N": FORCE_N}],
        },
        "slave": {
            "start": "finger",
            "contacts": [{"start_s": TOUCH_S[0], "end_s": TOUCH_S[1], "object": "obj", "force_N": FORCE_N}],
        },
        "noise": {"seed": 1, "T_sigma_C": 0.02, "Q_sigma_W": 0.002, "cutoff_Hz": 5.0},
    }
    return sim.scene.parse_scene(raw, f"<link loss bench {material}>")


def run_object(material: str) -> dict[str, Any]:
    """The skin error (RMS over the fallback's window, °C) of each run, and the traces."""
    sc = _scene(material)
    base = default_params(Role.MASTER, period_s=0.01)
    out: dict[str, Any] = {"traces": {}}
    for run in RUNS:
        pm = dataclasses.replace(base, link_loss_render_s=0.0 if run == "neutral_ramp" else RENDER_S)
        loss = None if run == "telepresence" else (LOSS_S, float("inf"))
        rec = run_offline_session(sc, master_params=pm, peer_loss_s=loss).recording
        t, skin, direct = rec.col("t_s"), rec.col("m_true_finger_C"), rec.col("ref_T_contact_C")
        m = (t >= LOSS_S) & (t < LOSS_S + RENDER_S)
        out[run] = float(np.sqrt(np.mean((skin[m] - direct[m]) ** 2)))
        out["traces"][run] = skin
        out["traces"]["t"], out["traces"]["direct"] = t, direct
    return out


def link_loss_figures(quick: bool) -> dict[str, Any]:
    """``link_loss_fallback_error_C``, ``link_loss_neutral_ramp_error_C`` (means over the objects, °C) and the
    per-object rows ``link_loss`` (material, fallback_C, neutral_ramp_C, telepresence_C) (JSON-ready)."""
    rows = []
    for label, material in QUICK_OBJECTS if quick else OBJECTS:
        r = run_object(material)
        rows.append({"material": label, **{f"{k}_C": round(r[k], 4) for k in RUNS}})
    return {
        "link_loss_fallback_error_C": round(float(np.mean([r["fallback_C"] for r in rows])), 4),
        "link_loss_neutral_ramp_error_C": round(float(np.mean([r["neutral_ramp_C"] for r in rows])), 4),
        "link_loss_window_s": [LOSS_S - TOUCH_S[0], LOSS_S - TOUCH_S[0] + RENDER_S],
        "link_loss": rows,
        "link_loss_quick": quick,
    }
