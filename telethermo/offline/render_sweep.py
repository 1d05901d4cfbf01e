"""Render mode across the envelope's object temperatures (issue 22 item 5): one 4 s touch per (material,
object
temperature), the display alone (yamamoto eq. 1/5/7) against the same finger touching the real object.

For each touch: eq. 1's contact temperature (the finger's natural skin against the object, table
effusivities),
whether it lies inside the skin clamps' band [T_min + 0.5, T_max − 0.5] °C, the early (0–1 s) RMS of the skin
against the direct touch, the eq. 7 pre-set the display asked for and what it got, the current at 0.9 s
against
its limit, and the skin's closest approach during the touch to the clamp it was asked beyond. Outside the band
the skin should sit at the clamp (within 0.5 °C, or as near as the current allows: ``limited_by`` says which
limit acted at 0.9 s).

Where the skin clamp stopped eq. 7's pre-set (``limited_by`` has ``preset_clamp``), the same touch runs again
with the clamps widened to :data:`UNCLAMPED_C` (a research envelope): ``early_rms_unclamped_C`` is what the
clamp on the pad costs, and ``skin_extreme_unclamped_C`` how far the skin itself then went (DESIGN.md §6: the
limits should act on the skin, not on a pad that the finger lands on at a different temperature).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from telethermo.control.coreparams import CoreParams
from telethermo.control.params import default_params
from telethermo.control.types import Role
from telethermo.offline.one_touch import one_touch_scene
from telethermo.offline.runner import run_offline_session
from telethermo.sim.materials import materials

SCENE = "virtual_materials"
MATERIALS = ("eps", "oak", "glass", "stainless_steel", "aluminium", "copper")
OBJECT_T_C = (5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0, 45.0, 50.0)
T_ON_S, T_OFF_S = 5.0, 9.0
BAND_MARGIN_C = 0.5
#: the research envelope's clamps for the unclamped re-run, °C
UNCLAMPED_C = (5.0, 50.0)


def render_touch(material: str, T_object_C: float, table: dict[str, float] | None = None) -> dict[str, Any]:
    """One rendered touch of ``material`` at ``T_object_C`` (see the module docstring) with the rendering
    table ``table`` (material -> β; default the shipped one)."""
    row = _touch(material, T_object_C, research=False, table=table)
    if "preset_clamp" in row["limited_by"]:
        wide = _touch(material, T_object_C, research=True, table=table)
        row["early_rms_unclamped_C"] = wide["early_rms_C"]
        row["preset_unclamped_C"] = wide["preset_asked_C"]
        row["skin_extreme_unclamped_C"] = wide["skin_extreme_C"]
    return row


def render_touch_both(material: str, T_object_C: float, table: dict[str, float]) -> dict[str, Any]:
    """:func:`render_touch` with the operator's ``table``, and beside it (``early_rms_shipped_table_C``) the
    same touch rendered with the shipped table (the baseline the operator's calibration must beat)."""
    row = render_touch(material, T_object_C, table)
    row["early_rms_shipped_table_C"] = _touch(material, T_object_C, research=False, table=None)["early_rms_C"]
    return row


def _research_params(period_s: float) -> CoreParams:
    """The master's defaults with the clamps widened to :data:`UNCLAMPED_C` (research envelope)."""
    p = default_params(Role.MASTER, period_s=period_s)
    lo, hi = UNCLAMPED_C
    return dataclasses.replace(p, safety=dataclasses.replace(p.safety, T_min_C=lo, T_max_C=hi, research=True))


def _touch(
    material: str, T_object_C: float, *, research: bool, table: dict[str, float] | None
) -> dict[str, Any]:
    sc = one_touch_scene(SCENE, material, T_object_C, T_ON_S, T_OFF_S)
    res = run_offline_session(
        sc,
        master_params=_research_params(sc.period_s) if research else None,
        render_options={"table": table} if table is not None else None,
    )
    rec = res.recording
    t, skin, ref = rec.col("t_s"), rec.col("m_true_surface_C"), rec.col("ref_T_contact_C")
    sp, cur = rec.col("m_setpoint_C"), rec.col("m_current_A")
    lim = rec.meta["master_params"]["safety"]
    lo, hi = float(lim["T_min_C"]), float(lim["T_max_C"])
    I_lim = float(lim["current_fraction"]) * float(lim["I_max_A"])
    mats = materials()
    pre = int(np.searchsorted(t, T_ON_S - 0.05))
    T_f = float(ref[pre])  # the direct-touch finger just before the touch (in air)
    b_f, b_o = mats["skin"].b, mats[material].b
    Tc = (b_f * T_f + b_o * T_object_C) / (b_f + b_o)
    early = (t >= T_ON_S) & (t < T_ON_S + 1.0)
    k = int(np.searchsorted(t, T_ON_S + 0.9))
    inside = lo + BAND_MARGIN_C <= Tc <= hi - BAND_MARGIN_C
    clamp = lo if Tc < lo + BAND_MARGIN_C else hi
    limited = [
        name
        for name, hit in (
            ("current", abs(cur[k]) >= 0.98 * I_lim),
            ("preset_clamp", sp[pre] <= lo + 1e-6 or sp[pre] >= hi - 1e-6),
        )
        if hit
    ]
    return {
        "material": material,
        "T_object_C": T_object_C,
        "T_finger_C": T_f,
        "T_contact_eq1_C": Tc,
        "inside_band": inside,
        "early_rms_C": float(np.sqrt(np.mean((skin[early] - ref[early]) ** 2))),
        "preset_asked_C": float(sp[pre]),
        "skin_at_0p9s_C": float(skin[k]),
        "current_at_0p9s_A": float(cur[k]),
        "clamp_C": None if inside else clamp,
        "skin_to_clamp_C": None if inside else _closest(skin[(t >= T_ON_S) & (t < T_OFF_S)], clamp, lo),
        "limited_by": limited,
        "skin_extreme_C": _extreme(skin[(t >= T_ON_S) & (t < T_OFF_S)], Tc, T_f),
    }


def _extreme(skin_C: np.ndarray, T_contact_C: float, T_finger_C: float) -> float:
    """The skin's extreme during the touch on the side the touch pulls it (coldest for a cold object), °C."""
    return float(np.min(skin_C) if T_contact_C <= T_finger_C else np.max(skin_C))


def _closest(skin_C: np.ndarray, clamp_C: float, lo_C: float) -> float:
    """How far the skin's extreme during the touch stays from ``clamp_C``, °C (negative: beyond the clamp)."""
    return float(np.min(skin_C) - clamp_C) if clamp_C == lo_C else float(clamp_C - np.max(skin_C))


def summarise(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Worst early RMS inside the band (the target: <= 0.5 °C), and beyond it how near the clamp the skin
    got."""
    inside = [r for r in rows if r["inside_band"]]
    outside = [r for r in rows if not r["inside_band"]]
    worst = max(inside, key=lambda r: r["early_rms_C"]) if inside else None
    near = [r["skin_to_clamp_C"] for r in outside]
    return {
        "render_n_touches": len(rows),
        "render_inside_band": len(inside),
        "render_early_rms_worst_C": worst["early_rms_C"] if worst else math.nan,
        "render_early_rms_worst_touch": worst,
        "render_early_rms_median_C": float(np.median([r["early_rms_C"] for r in inside]))
        if inside
        else math.nan,
        "render_inside_band_over_0p5": [
            (r["material"], r["T_object_C"], round(r["early_rms_C"], 3), r["limited_by"])
            for r in inside
            if r["early_rms_C"] > 0.5
        ],
        **_clamp_cost(inside),
        **_shipped_table(inside),
        "render_beyond_band_skin_to_clamp_worst_C": float(max(near)) if near else math.nan,
        "render_beyond_band_at_clamp_within_0p5": int(sum(d <= 0.5 for d in near)),
        "render_beyond_band": len(outside),
    }


def _shipped_table(inside: list[dict[str, Any]]) -> dict[str, Any]:
    """The shipped table's figures on the same touches (where the sweep ran it: :func:`render_touch_both`)."""
    both = [r for r in inside if "early_rms_shipped_table_C" in r]
    if not both:
        return {}
    rms = [r["early_rms_shipped_table_C"] for r in both]
    free = [r["early_rms_shipped_table_C"] for r in both if "early_rms_unclamped_C" not in r]
    return {
        "render_early_rms_median_shipped_table_C": float(np.median(rms)),
        "render_early_rms_worst_not_clamped_shipped_table_C": max(free, default=math.nan),
    }


def _clamp_cost(inside: list[dict[str, Any]]) -> dict[str, Any]:
    """What the skin clamp on the pad's pre-set costs inside the band: the touches it limited, the worst early
    RMS of the others, the worst with the clamp widened, and how far the skin went then, °C."""
    clamped = [r for r in inside if "early_rms_unclamped_C" in r]
    free = [r for r in inside if "early_rms_unclamped_C" not in r]
    nan = math.nan
    return {
        "render_inside_band_preset_clamped": len(clamped),
        "render_early_rms_worst_not_clamped_C": max((r["early_rms_C"] for r in free), default=nan),
        "render_early_rms_worst_unclamped_C": max(
            (r.get("early_rms_unclamped_C", r["early_rms_C"]) for r in inside), default=nan
        ),
        "render_unclamped_skin_extremes_C": [
            (r["material"], r["T_object_C"], round(r["skin_extreme_unclamped_C"], 2)) for r in clamped
        ],
    }
