"""Scores of the material bench's envelope run (bench/material_id_envelope.py): the expected calibration
error and its floor, the figures of the touches beyond the envelope, the fit's slowest cycle position."""

from __future__ import annotations

from typing import Any, cast

import numpy as np

#: posterior at and above which an answer counts as confident
CONFIDENT = 0.9
#: the label draws of the ECE floor (a perfectly calibrated classifier at the same posteriors)
ECE_FLOOR_SEED = 60606


def ece_floor(post: np.ndarray, draws: int = 400, seed: int = ECE_FLOOR_SEED) -> float | None:
    """The ECE a perfectly calibrated classifier would show on answers with posteriors ``post``: each answer
    right with probability its posterior, the median over ``draws`` such label draws. The baseline of
    :func:`ece` at this many answers (its sampling noise): an ECE near the floor is as calibrated as
    ``post.size`` answers can show."""
    if post.size == 0:
        return None
    rng = np.random.default_rng(seed)
    vals = [cast(float, ece(post, rng.random(post.size) < post)) for _ in range(draws)]
    return float(np.median(vals))


def ece(post: np.ndarray, right: np.ndarray, bins: int = 10) -> float | None:
    """Expected calibration error of answers with posteriors ``post`` (10 equal bins on [0, 1])."""
    if post.size == 0:
        return None
    idx = np.minimum((post * bins).astype(int), bins - 1)
    return float(
        sum(
            abs(post[idx == b].mean() - right[idx == b].mean()) * np.sum(idx == b)
            for b in range(bins)
            if np.any(idx == b)
        )
        / post.size
    )


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
