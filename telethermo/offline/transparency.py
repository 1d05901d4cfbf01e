"""What the operator feels: per-touch transparency figures against the direct-touch finger (issue 11).

The truth is the simulator's *direct touch*: the same finger touching the same object with no display in
between (``ref_T_contact_C``, ``ref_Q_into_finger_W``). The operator's skin on the display is
``m_true_surface_C`` (the finger's skin on the pad) and the heat the pad exchanges with it
``m_true_Q_into_body_W`` (> 0 heats the finger). Per touch of the probe (t_on = the scene's contact):

============ ============================== ==================================================================
figure       window                         meaning
============ ============================== ==================================================================
pre_C        [t_on − 0.5 s, t_on)           mean |skin − direct skin|: the finger before the touch
early_C      [t_on, t_on + 1 s)             mean |skin − direct skin|: yamamoto's early phase, the
                                            material cue
early01_C    [t_on + 0.1 s, t_on + 1 s)     the same without the first 0.1 s (the earlier figure; secondary)
late_C       [t_on + 1 s, t_on + 3 s)       mean |skin − direct skin|
window_C     [t_on − 0.5 s, t_on + 1 s)     mean |skin − direct skin| over the approach and the early phase:
                                            the **headline** averages it over the touches. A display that
                                            ignores the probe cannot game it: it must keep the finger natural
                                            before the touch *and* follow the object after.
cue_J        [t_on, t_on + 1 s]             heat drawn out of the finger, J (display); direct_cue_J the
                                            same in direct touch
dskin_C      t_on → t_on + 1 s              skin change (display; direct_dskin_C in direct touch); also at
                                            0.5 s and 3 s (``dskin_at``)
============ ============================== ==================================================================

Windows after the contact are clipped at the release. **Discrimination** is judged on the cue: for every
pair of materials the direct-touch order of the mean cue must be kept by the display, and the contrast ratio
(cue_a − cue_b)_display / (cue_a − cue_b)_direct says how much of the direct contrast the display conveys
(1 = all of it; ≤ 0 = order lost).

All functions are pure (arrays in, numbers out).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

PRE_S = 0.5
EARLY_S = 1.0
EARLY_SKIP_S = 0.1
LATE_S = (1.0, 3.0)
DSKIN_AT_S = (0.5, 1.0, 3.0)


def _mask(t: np.ndarray, t0: float, t1: float, t_off: float | None = None) -> np.ndarray:
    """Samples with t0 <= t < t1 (t1 clipped at the release ``t_off``, inclusive)."""
    if t_off is not None and t_off < t1:
        return (t >= t0 - 1e-9) & (t <= t_off + 1e-9)
    return (t >= t0 - 1e-9) & (t < t1 - 1e-9)


def _mean_abs(x: np.ndarray) -> float:
    x = x[np.isfinite(x)]
    return float(np.mean(np.abs(x))) if x.size else math.nan


def _finite_mean(v: list[float]) -> float:
    x = np.asarray(v, dtype=float)
    x = x[np.isfinite(x)]
    return float(x.mean()) if x.size else math.nan


def _at(t: np.ndarray, y: np.ndarray, ts: float) -> float:
    """y at the last sample at or before ``ts`` (NaN outside the record: before its first sample, or more
    than one period after its last, as for a touch a shortened session never reached)."""
    if len(t) == 0:
        return math.nan
    if ts > t[-1]:  # the period only matters past the record's end (a median over the whole record)
        period = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
        if ts > t[-1] + period + 1e-9:
            return math.nan
    k = int(np.searchsorted(t, ts + 1e-9, side="right")) - 1
    return float(y[k]) if 0 <= k < len(y) else math.nan


def heat_J(t: np.ndarray, q_W: np.ndarray, t0: float, t1: float) -> float:
    """∫ q dt over [t0, t1), J (rectangle rule on the sample grid: each sample holds for one period)."""
    m = _mask(t, t0, t1)
    if m.sum() == 0:
        return math.nan
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    q = q_W[m]
    return float(np.sum(np.where(np.isfinite(q), q, 0.0)) * dt)


def touch_figures(
    t: np.ndarray,
    skin: np.ndarray,
    ref: np.ndarray,
    q_finger_W: np.ndarray,
    q_ref_finger_W: np.ndarray,
    t_on: float,
    t_off: float,
) -> dict[str, Any]:
    """The figures of one touch (see the module docstring). ``q_*`` are heat flows into the finger, W."""
    err = skin - ref
    t_end_early = min(t_on + EARLY_S, t_off + 1e-9)
    out = {
        "pre_C": _mean_abs(err[_mask(t, t_on - PRE_S, t_on)]),
        "early_C": _mean_abs(err[_mask(t, t_on, t_on + EARLY_S, t_off)]),
        "early01_C": _mean_abs(err[_mask(t, t_on + EARLY_SKIP_S, t_on + EARLY_S, t_off)]),
        "late_C": _mean_abs(err[_mask(t, t_on + LATE_S[0], t_on + LATE_S[1], t_off)]),
        "window_C": _mean_abs(err[_mask(t, t_on - PRE_S, t_on + EARLY_S, t_off)]),
        "cue_J": -heat_J(t, q_finger_W, t_on, t_end_early),
        "direct_cue_J": -heat_J(t, q_ref_finger_W, t_on, t_end_early),
    }
    s0, r0 = _at(t, skin, t_on - 1e-6), _at(t, ref, t_on - 1e-6)
    dsk = {}
    for d in DSKIN_AT_S:
        ts = min(t_on + d, t_off)
        dsk[f"{d:g}s"] = {"display_C": _at(t, skin, ts) - s0, "direct_C": _at(t, ref, ts) - r0}
    out["dskin_C"] = dsk["1s"]["display_C"]
    out["direct_dskin_C"] = dsk["1s"]["direct_C"]
    out["dskin_at"] = dsk
    return out


def cue_discrimination(per_touch: list[dict[str, Any]]) -> dict[str, Any]:
    """Order and contrast of the material cue (heat drawn in the first second), display vs direct touch.

    ``per_touch``: dicts with ``object``, ``cue_J`` and ``direct_cue_J``. Returns the per-material mean
    cues, the direct order (most heat drawn first) of the materials with a cue (``n_materials_compared``;
    fewer than two: no pair, and ``order_kept`` False), whether the display keeps it on every pair, and the
    contrast ratio of every pair."""
    mats: dict[str, dict[str, list[float]]] = {}
    for p in per_touch:
        m = mats.setdefault(p.get("object") or "?", {"display": [], "direct": []})
        m["display"].append(p["cue_J"])
        m["direct"].append(p["direct_cue_J"])
    table = {
        k: {
            "display_J": _finite_mean(v["display"]),
            "direct_J": _finite_mean(v["direct"]),
            "touches": len(v["display"]),
        }
        for k, v in mats.items()
    }
    # a material whose touches left no cue (a session ended before them) is in no pair
    scored = [k for k, v in table.items() if math.isfinite(v["display_J"]) and math.isfinite(v["direct_J"])]
    order = sorted(scored, key=lambda k: -table[k]["direct_J"])
    pairs = []
    for i, a in enumerate(order):
        for b in order[i + 1 :]:
            d_dir = table[a]["direct_J"] - table[b]["direct_J"]
            d_dis = table[a]["display_J"] - table[b]["display_J"]
            ratio = d_dis / d_dir if d_dir > 0 else math.nan
            pairs.append(
                {
                    "pair": [a, b],
                    "direct_J": d_dir,
                    "display_J": d_dis,
                    "contrast_ratio": ratio,
                    "order_kept": bool(d_dis > 0),
                }
            )
    ratios = [p["contrast_ratio"] for p in pairs if math.isfinite(p["contrast_ratio"])]
    return {
        "materials": table,
        "direct_order_most_heat_first": order,
        "order_kept": bool(pairs) and all(p["order_kept"] for p in pairs),
        "n_materials_compared": len(order),
        "pairs": pairs,
        "contrast_ratio_min": float(min(ratios)) if ratios else math.nan,
    }


def transparency_figures(
    t: np.ndarray,
    skin: np.ndarray,
    ref: np.ndarray,
    q_finger_W: np.ndarray,
    q_ref_finger_W: np.ndarray,
    contacts: list[dict[str, Any]],
) -> dict[str, Any]:
    """Per-touch figures and their means; ``headline_error_C`` = mean of the touches' ``window_C``."""
    per = []
    for c in contacts:
        f = touch_figures(t, skin, ref, q_finger_W, q_ref_finger_W, c["t_on_s"], c["t_off_s"])
        per.append({"object": c.get("object", ""), "t_on_s": c["t_on_s"], "t_off_s": c["t_off_s"], **f})

    def mean(key: str) -> float:
        v = [p[key] for p in per if math.isfinite(p[key])]
        return float(np.mean(v)) if v else math.nan

    return {
        "headline_error_C": mean("window_C"),
        "pre_contact_mean_error_C": mean("pre_C"),
        "early_mean_error_C": mean("early_C"),
        "early01_mean_error_C": mean("early01_C"),
        "late_mean_error_C": mean("late_C"),
        "per_touch": per,
        "cue": cue_discrimination(per),
    }
