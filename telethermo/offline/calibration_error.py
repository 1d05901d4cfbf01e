"""The expected calibration error of a classifier's answers and its floors: what a perfectly calibrated
classifier would show on the same posteriors (each answer right with the probability it states), per stratum
and for the worst of several strata. Shared by the material bench (bench/material_id_envelope.py) and the
tests."""

from __future__ import annotations

from typing import cast

import numpy as np

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


def ece_worst_floor(posts: list[np.ndarray], draws: int = 400, seed: int = ECE_FLOOR_SEED) -> float | None:
    """The worst-stratum ECE a perfectly calibrated classifier would show on strata whose answers have
    posteriors ``posts`` (one array per stratum): each answer right with probability its posterior, the
    largest ECE over the strata, the median over ``draws`` such label draws. The baseline of the worst
    stratum's ECE: the largest of several noisy ECEs sits above each stratum's own floor, and at the bench's
    size it can sit above a target that a perfectly calibrated classifier meets in expectation."""
    posts = [p for p in posts if p.size]
    if not posts:
        return None
    rng = np.random.default_rng(seed)
    vals = [max(cast(float, ece(p, rng.random(p.size) < p)) for p in posts) for _ in range(draws)]
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
