"""Scores of the material bench's envelope run (bench/material_id_envelope.py): the expected calibration
error and its floor, the figures of the touches beyond the envelope, the fit's slowest cycle position."""

from __future__ import annotations

from typing import Any

import numpy as np

# the calibration error and its floors live in the library (the tests use them too); re-exported
from telethermo.offline.calibration_error import ECE_FLOOR_SEED, ece, ece_floor, ece_worst_floor

__all__ = ["CONFIDENT", "ECE_FLOOR_SEED", "ece", "ece_floor", "ece_worst_floor", "outside_figures"]

#: posterior at and above which an answer counts as confident
CONFIDENT = 0.9


def outside_figures(rows: list[dict]) -> dict[str, Any]:
    """Per kind of condition beyond the envelope and over all: how many answers are "unknown" (refined /
    early), how often the named ones are right, and the confident ones (posterior ≥ 0.9)."""

    def one(rs: list[dict]) -> dict[str, Any]:
        truth = np.array([r["class"] for r in rs])
        out: dict[str, Any] = {"n": len(rs)}
        for stage, a_key, p_key in (
            ("late", "answer", "posterior"),
            ("early", "answer_early", "posterior_early"),
        ):
            ans, post = np.array([r[a_key] for r in rs]), np.array([r[p_key] for r in rs])
            named, conf = ans >= 0, (ans >= 0) & (post >= CONFIDENT)
            out[stage] = {
                "unknown_fraction": round(float(np.mean(~named)), 3),
                "named_accuracy": round(float(np.mean(ans[named] == truth[named])), 3)
                if named.any()
                else None,
                "confident_n": int(conf.sum()),
                "confident_precision": (
                    round(float(np.mean(ans[conf] == truth[conf])), 3) if conf.any() else None
                ),
            }
        return out

    kinds = sorted({r["kind"] for r in rows})
    return {"all": one(rows)} | {k: one([r for r in rows if r["kind"] == k]) for k in kinds}


def position_worst_ms(rows: list[dict]) -> float | None:
    """The slowest cycle position of the early fit: per position after the window the median over touches,
    then the largest. What the work costs, immune to the scheduler's occasional preemption of one cycle
    that a per-touch maximum picks up on a loaded machine."""
    pos = [r["fit_positions_ms"] for r in rows if r["fit_positions_ms"]]
    if not pos:
        return None
    n = min(len(x) for x in pos)
    return float(np.max(np.median(np.array([x[:n] for x in pos]), axis=0)))
