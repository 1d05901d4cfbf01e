"""Robust selection of the tuned point: the best few distinct search points and the reference are
checked at ±``rel`` (30 %) on each gain, one at a time, plus a few seeded random corners of the
±``rel`` box; among the points whose centre is no worse than the reference's, the one with the best
*worst case* wins (ties broken by the centre value). :func:`tune` runs the search and this check.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from telethermo.tuning.objective import UNSTABLE_J, Evaluation, Objective
from telethermo.tuning.search import SearchPoint, SearchResult, search
from telethermo.tuning.space import GainSpec, clip_gains, default_gains


def box_points(
    gains: dict[str, float], space: Sequence[GainSpec], *, rel: float = 0.3, corners: int = 4, seed: int = 0
) -> list[tuple[str, dict[str, float]]]:
    """(label, gains) of the ±``rel`` box around ``gains``: each gain ×(1−rel) and ×(1+rel) alone,
    then ``corners`` seeded random corners (every gain at ±rel). Not clipped to the search bounds:
    the box asks how the *chosen* point behaves when the real plant differs."""
    pts: list[tuple[str, dict[str, float]]] = []
    for s in space:
        for sign, f in (("-", 1.0 - rel), ("+", 1.0 + rel)):
            g = dict(gains)
            g[s.key] = gains[s.key] * f
            pts.append((f"{s.key} {sign}{rel:.0%}", g))
    rng = np.random.default_rng(seed)
    for i in range(corners):
        signs = rng.choice([-1.0, 1.0], size=len(space))
        g = dict(gains)
        for s, sg in zip(space, signs):
            g[s.key] = gains[s.key] * (1.0 + sg * rel)
        pts.append(("corner " + "".join("+" if sg > 0 else "-" for sg in signs), g))
    return pts


@dataclass
class Robustness:
    """The objective at a point and over its ±rel box."""

    centre: Evaluation
    rows: list[tuple[str, Evaluation]]

    @property
    def worst(self) -> Evaluation:
        return max([self.centre] + [e for _, e in self.rows], key=lambda e: e.J)

    @property
    def worst_label(self) -> str:
        w = self.worst
        return next((lab for lab, e in self.rows if e is w), "centre")


def robustness(
    objective: Objective, gains: dict[str, float], *, rel: float = 0.3, corners: int = 4, seed: int = 0
) -> Robustness:
    """Evaluate ``gains`` and its ±``rel`` box (:func:`box_points`)."""
    centre = objective.evaluate(gains)
    rows = [
        (lab, objective.evaluate(g))
        for lab, g in box_points(gains, objective.space, rel=rel, corners=corners, seed=seed)
    ]
    return Robustness(centre, rows)


@dataclass
class TuneResult:
    """A tuning run: the search, the robustness of the candidates, the chosen point."""

    search: SearchResult
    candidates: list[Robustness]
    chosen: Robustness
    reference: Robustness | None
    rel: float

    @property
    def best(self) -> Evaluation:
        return self.chosen.centre


def distinct_best(
    points: Sequence[SearchPoint], space: Sequence[GainSpec], k: int, *, min_log_distance: float = 0.1
) -> list[SearchPoint]:
    """The ``k`` best search points (by the searched value) whose log-gains differ by more than
    ``min_log_distance`` (max norm)."""
    out: list[SearchPoint] = []
    for p in sorted(points, key=lambda p: (p.value, p.centre.J)):
        if p.value >= UNSTABLE_J:
            break
        x = np.array([math.log(p.gains[s.key]) for s in space])
        if all(
            np.max(np.abs(x - np.array([math.log(o.gains[s.key]) for s in space]))) > min_log_distance
            for o in out
        ):
            out.append(p)
        if len(out) >= k:
            break
    return out


def tune(
    objective: Objective,
    *,
    budget: int = 60,
    method: str = "nelder-mead",
    seed: int = 0,
    candidates: int = 3,
    rel: float = 0.3,
    corners: int = 4,
    stress_rel: float | None = None,
    x0: dict[str, float] | None = None,
    reference: dict[str, float] | None = None,
    on_stage: Callable[[str], None] | None = None,
) -> TuneResult:
    """Search (``budget`` points, stress corners at ``stress_rel``, default ``rel``), then check the
    best ``candidates`` distinct points and the ``reference`` (default: the shipped gains) over the
    ±``rel`` box (:func:`robustness`) and choose the best worst case (ties: the best centre) among
    those whose centre is no worse than the reference's (so the reference wins if none is)."""
    say = on_stage or (lambda _m: None)
    stress_rel = rel if stress_rel is None else stress_rel
    say(
        f"search: {method}, budget {budget} points, {len(objective.space)} gains, "
        f"{len(objective.scenes)} scenes, stress corners ±{stress_rel:.0%}"
    )
    sr = search(objective, budget=budget, method=method, seed=seed, x0=x0, stress_rel=stress_rel)
    cands = distinct_best(sr.points, objective.space, candidates)
    ref_g = clip_gains(
        reference if reference is not None else default_gains(objective.space), objective.space
    )
    robs: list[Robustness] = []
    for i, p in enumerate(cands):
        say(
            f"robustness of candidate {i + 1}/{len(cands)} "
            f"(J = {p.centre.J:.3f}, searched value {p.value:.3f})"
        )
        robs.append(robustness(objective, p.gains, rel=rel, corners=corners, seed=seed))
    ref_key = objective.memo_key(ref_g)
    ref_rob = next((r for r in robs if objective.memo_key(r.centre.gains) == ref_key), None)
    if ref_rob is None:
        say("robustness of the reference point")
        ref_rob = robustness(objective, ref_g, rel=rel, corners=corners, seed=seed)
    pool = robs + ([ref_rob] if ref_rob not in robs else [])
    # better AND more robust: a candidate must not be worse than the reference at the centre
    eligible = [r for r in pool if r.centre.J <= ref_rob.centre.J + 1e-12]
    chosen = min(eligible, key=lambda r: (r.worst.J, r.centre.J))
    return TuneResult(search=sr, candidates=robs, chosen=chosen, reference=ref_rob, rel=rel)
