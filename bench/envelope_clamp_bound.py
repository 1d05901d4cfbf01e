"""Do the skin clamps explain issue 22's gap to the bound? ``python -m bench.envelope_clamp_bound
[--workers N]`` writes ``bench/results/envelope_clamp_bound.json``.

The optimal-current bound (``bound_conditions`` of bench/results/envelope.json; telethermo/offline/bound.py)
limits the display's current only: on a 5 °C or 50 °C object it lets the skin follow the direct touch
beyond the envelope's skin clamps (DESIGN.md §6, [15, 43] °C), which no conforming display may do. A second
bound, exact and cheap, relaxes the other way: the **clamped ideal display**, a skin that is at every sample
the direct touch's skin clipped to the clamps widened by SKIN_MARGIN_C (any plant, any current). It has no
ramp: the ramp bounds the setpoint, not the skin, and a display's skin outruns its 5 °C/s setpoint ramp in
contact (``display_skin_where_clamps_bind``: up to 21 °C/s over 50 ms). Its error is the part of the direct
touch no display inside the clamps can render, scored with the headline's own windows
(telethermo.offline.transparency). Every display whose skin stays within them does at least as badly as
the clamped ideal display, whatever its finger's state; the optimal-current bound assumes the finger matched
to the direct touch's at each window's start, and under that same assumption
``max(optimal-current bound, clamped ideal display)`` bounds the subset's conditions too: the ratio to it says
how much of the gap the clamps account for.

Per condition, against the best constant pad of the same condition (the trivial baseline, from
envelope.json's matrix): ``clamp_bound_beats_best_pad_fraction`` is the share of conditions in which a
display held only by the clamps could beat the pad (1.0: the clamps exclude none of the target ≥ 0.9).
"""

from __future__ import annotations

import argparse
import json
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np

from bench.common import RESULTS_DIR, write_results
from bench.transparency_bench import reference_track
from telethermo.offline.envelope import SKIN_CLAMP_C, Condition, condition_scene, condition_session
from telethermo.offline.transparency import transparency_figures
from telethermo.recording.rows import scene_contacts

#: the clamped ideal display's skin may lie this far beyond the clamps, °C: they act on the skin's estimate,
#: and the true skin has been measured 0.15 °C past 43 °C (condition 30, ``display_skin_where_clamps_bind``)
SKIN_MARGIN_C = 0.5
#: the window of the display skin's rate, s (5 periods at 10 ms)
RATE_WINDOW_S = 0.05


def clamp_bound(cond: dict[str, Any]) -> dict[str, Any]:
    """The clamped ideal display's headline and early error of one condition (°C; the nominal clamps'
    headline beside), and the direct touch's skin range."""
    c = Condition.from_json(cond)
    sc, _ = condition_scene(c)
    t, skin_ref, q_ref, _cells = reference_track(sc)
    lo, hi = SKIN_CLAMP_C[0] - SKIN_MARGIN_C, SKIN_CLAMP_C[1] + SKIN_MARGIN_C
    contacts = scene_contacts(sc, "slave")
    f = transparency_figures(t, np.clip(skin_ref, lo, hi), skin_ref, np.zeros_like(t), q_ref, contacts)
    nominal = transparency_figures(
        t, np.clip(skin_ref, *SKIN_CLAMP_C), skin_ref, np.zeros_like(t), q_ref, contacts
    )
    return {
        "index": c.index,
        "clamp_bound_headline_C": f["headline_error_C"],
        "clamp_bound_early_C": f["early_mean_error_C"],
        "clamp_bound_nominal_headline_C": nominal["headline_error_C"],
        "direct_skin_range_C": [float(np.min(skin_ref)), float(np.max(skin_ref))],
    }


def display_skin(cond: dict[str, Any]) -> dict[str, Any]:
    """The shipped display's skin in one condition's session (identified gains, as the matrix runs it): its
    extremes (°C; inside the clamps, the clamped ideal display bounds it) and its fastest change over
    RATE_WINDOW_S (°C/s; beyond the 5 °C/s setpoint ramp, a ramp-limited ideal display would not bound
    it). Run on the subset's conditions where the nominal clamps bind."""
    c = Condition.from_json(cond)
    sc, res, _fits = condition_session(c)
    skin = res.recording.col("m_true_surface_C")
    n = max(int(round(RATE_WINDOW_S / sc.period_s)), 1)
    return {
        "index": c.index,
        "skin_min_C": float(np.nanmin(skin)),
        "skin_max_C": float(np.nanmax(skin)),
        "skin_rate_max_C_per_s": float(np.nanmax(np.abs(skin[n:] - skin[:-n])) / (n * sc.period_s)),
    }


def against_bounds(ours_C: float, pad_C: float, bound_C: float, clamp_bound_C: float) -> dict[str, Any]:
    """A headline (°C) against the optimal-current bound and the safe bound, max(it, the clamped ideal
    display): the ratios and the captured share of what the safe bound gains over the best pad (None where
    it gains nothing)."""
    safe = max(bound_C, clamp_bound_C)
    return {
        "safe_bound_headline_C": safe,
        "ratio_to_bound": ours_C / bound_C,
        "ratio_to_safe_bound": ours_C / safe,
        "captured_fraction_safe": (pad_C - ours_C) / (pad_C - safe) if pad_C > safe else None,
    }


def subset(env: dict[str, Any], by: dict[int, dict[str, Any]]) -> dict[str, Any]:
    """The bound subset: the ratio to the optimal-current bound and to max(it, the clamped ideal display)."""
    per = []
    for b in env["bound_conditions"]:
        cb = by[b["index"]]["clamp_bound_headline_C"]
        per.append(
            {
                "index": b["index"],
                "headline_C": b["headline_C"],
                "bound_headline_C": b["bound_headline_C"],
                "clamp_bound_headline_C": cb,
                "clamp_bound_nominal_headline_C": by[b["index"]]["clamp_bound_nominal_headline_C"],
                **against_bounds(b["headline_C"], b["best_pad_headline_C"], b["bound_headline_C"], cb),
            }
        )
    cap = [p["captured_fraction_safe"] for p in per if p["captured_fraction_safe"] is not None]
    return {
        "subset_median_ratio_to_bound": float(np.median([p["ratio_to_bound"] for p in per])),
        "subset_median_ratio_to_safe_bound": float(np.median([p["ratio_to_safe_bound"] for p in per])),
        "subset_captured_fraction_median_safe": float(np.median(cap)) if cap else None,
        "subset_clamps_bind": [
            p["index"] for p in per if p["clamp_bound_headline_C"] > p["bound_headline_C"]
        ],
        "subset_clamps_bind_nominal": [
            p["index"] for p in per if p["clamp_bound_nominal_headline_C"] > p["bound_headline_C"]
        ],
        "subset": per,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m bench.envelope_clamp_bound", description=__doc__.split("\n\n")[0]
    )
    ap.add_argument("--workers", type=int, default=2, help="processes (default 2)")
    ap.add_argument("--shipped", default=str(RESULTS_DIR / "envelope.json"), help="the matrix's results")
    a = ap.parse_args(argv)
    with open(a.shipped, encoding="utf-8") as f:
        env = json.load(f)
    rows = [r for r in env["conditions"] if "headline_C" in r] + [env["base"]]
    with ProcessPoolExecutor(max_workers=a.workers) as ex:
        out = list(ex.map(clamp_bound, [r["condition"] for r in rows], chunksize=4))
        by = {o["index"]: o for o in out}
        sub = subset(env, by)
        cond = {r["condition"]["index"]: r["condition"] for r in rows}
        skins = list(ex.map(display_skin, [cond[i] for i in sub["subset_clamps_bind_nominal"]]))
    scored = [(r, by[r["condition"]["index"]]) for r in rows if r["condition"]["index"] >= 0]
    beats = [o["clamp_bound_headline_C"] < r["best_pad_headline_C"] for r, o in scored]
    hb = np.array([o["clamp_bound_headline_C"] for _, o in scored])
    worst = int(np.argmax(hb))
    data = {
        "n_conditions": len(scored),
        "clamp_bound_beats_best_pad_fraction": float(np.mean(beats)),
        "controller_beats_best_pad_fraction": float(np.mean([r["beats_best_pad"] for r, _ in scored])),
        "clamp_bound_median_C": float(np.median(hb)),
        "clamp_bound_worst_C": float(hb[worst]),
        "clamp_bound_worst_condition": scored[worst][0]["condition"],
        "clamp_bound_nonzero_conditions": int(np.sum(hb > 1e-9)),
        **sub,
        "display_skin_where_clamps_bind": skins,
        "conditions": [{"index": r["condition"]["index"], **o} for r, o in scored],
    }
    path = write_results("envelope_clamp_bound", data)
    print(json.dumps({k: v for k, v in data.items() if k not in ("conditions", "subset")}, indent=1))
    print(f"written {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
