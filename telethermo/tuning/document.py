"""What a tuning run writes: the gains file (format :data:`GAINS_FORMAT`, read by the nodes
through :mod:`telethermo.control.gainsfile`) with the objective and the search that chose them, and the
run's full record (:func:`run_record`)."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from telethermo.control.defaults import GAINS
from telethermo.control.gainsfile import GAIN_FIELDS, GAINS_FORMAT, apply_marks
from telethermo.control.types import Role
from telethermo.tuning.objective import Objective
from telethermo.tuning.robust import Robustness, TuneResult


def gains_document(
    result: TuneResult, objective: Objective, *, extra: dict[str, Any] | None = None
) -> dict[str, Any]:
    """The gains file (format :data:`GAINS_FORMAT`, see docs/tuning.md) of a tuning run."""
    g = result.best.gains
    per_role: dict[str, dict[str, float]] = {"master": {}, "slave": {}}
    for role in per_role:
        for name in GAIN_FIELDS:  # every gain, searched or default, so the file is complete
            per_role[role][name] = float(g.get(f"{role}.{name}", GAINS[Role(role)][name]))
    doc = {
        "format": GAINS_FORMAT,
        "period_s": float(objective.scenes[0].period_s),
        "master": per_role["master"],
        "slave": per_role["slave"],
        "apply": apply_marks(),
        "objective": {
            "J": result.best.J,
            "worst_J_over_box": result.chosen.worst.J,
            "rel_box": result.rel,
            "scenes": [s.name for s in objective.scenes],
            "seed": objective.seed,
            "weights": dataclasses.asdict(objective.weights),
        },
        "search": {
            "method": result.search.method,
            "budget_points": result.search.budget,
            "seed": result.search.seed,
            "stress_rel": result.search.stress_rel,
            "evaluations": result.search.n_evaluations,
        },
    }
    if extra:
        doc.update(extra)
    return doc


def sensitivity_rows(rob: Robustness) -> list[dict[str, Any]]:
    """JSON rows of a Robustness (centre first), scene-averaged figures and per-scene J."""
    out = []
    for label, ev in [("centre", rob.centre)] + list(rob.rows):
        r = {"point": label, "gains": ev.gains, **ev.summary()}
        r["per_scene"] = [
            {
                k: s[k]
                for k in (
                    "scene",
                    "J",
                    "early_C",
                    "late_C",
                    "tracking_rms_C",
                    "limit_s",
                    "trips",
                    "order_kept",
                    "margins_C",
                    "margin_shortfall_C",
                    "per_contact_early_C",
                )
            }
            for s in ev.scenes
        ]
        out.append(r)
    return out


def run_record(
    result: TuneResult,
    objective: Objective,
    doc: dict[str, Any],
    *,
    scene: str,
    budget: int,
    method: str,
    seed: int,
    rel: float,
    corners: int,
    wall_time_s: float,
) -> dict[str, Any]:
    """Everything a tuning run did, as JSON (``telethermo tune --record``; bench/results/tuning.json):
    the space, the start, the search's best, every candidate's robustness, the sensitivity tables of
    the chosen point and of the reference, the gains file ``doc`` and every evaluation. A figure a
    session could not give (NaN, e.g. no late phase in a short scene) is written as null."""
    res, obj = result, objective
    pool = res.candidates + (
        [res.reference] if res.reference is not None and res.reference not in res.candidates else []
    )
    return _json_safe(
        {
            "scene": scene,
            "scenes": [s.name for s in obj.scenes],
            "budget": budget,
            "method": method,
            "seed": seed,
            "wall_time_s": wall_time_s,
            "evaluations": len(obj.history),
            "sessions": obj.n_sessions,
            "space": [{"gain": s.key, "lo": s.lo, "hi": s.hi} for s in obj.space],
            "weights": doc["objective"]["weights"],
            "rel_box": rel,
            "corners": corners,
            "stress_rel": res.search.stress_rel,
            "start": {
                "gains": res.search.start.gains,
                "searched_value": res.search.start.value,
                **res.search.start.centre.summary(),
            },
            "search_best": {
                "gains": res.search.best.gains,
                "searched_value": res.search.best.value,
                **res.search.best.centre.summary(),
            },
            "candidates": [
                {
                    "gains": r.centre.gains,
                    "J": r.centre.J,
                    "worst_J": r.worst.J,
                    "worst_at": r.worst_label,
                    "is_reference": r is res.reference,
                    "chosen": r is res.chosen,
                }
                for r in pool
            ],
            "chosen": {
                "gains": res.best.gains,
                "worst_J": res.chosen.worst.J,
                "worst_at": res.chosen.worst_label,
                **res.best.summary(),
            },
            "sensitivity_chosen": sensitivity_rows(res.chosen),
            "sensitivity_reference": sensitivity_rows(res.reference) if res.reference is not None else None,
            "gains_file": doc,
            "history": [
                {
                    "gains": ev.gains,
                    **ev.summary(),
                    "per_scene_J": [sc["J"] for sc in ev.scenes],
                    "per_scene_early_C": [sc["early_C"] for sc in ev.scenes],
                    "per_scene_tracking_rms_C": [sc["tracking_rms_C"] for sc in ev.scenes],
                }
                for ev in obj.history
            ],
        }
    )


def _json_safe(x: Any) -> Any:
    """``x`` with every non-finite float replaced by None (JSON has no NaN)."""
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {k: _json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_json_safe(v) for v in x]
    return x
