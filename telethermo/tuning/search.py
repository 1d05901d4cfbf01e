"""The bounded search over the log-gain box, steered off the stability cliff by stress corners.

Every point the optimiser proposes is clipped to the bounds *before* a session runs (and recorded:
tests check that none leaves them). The search minimises the worst of a point and its two *stress
corners* (:func:`stress_corners`). Deterministic for a seed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np
import scipy.optimize as so

from telethermo.tuning.objective import Evaluation, Objective
from telethermo.tuning.space import GainSpec, clip_gains, default_gains


#: the log-gain box, (low, high) per axis; the search's cost of a point in log-gains
_Bounds = list[tuple[float, float]]
_Cost = Callable[[np.ndarray], float]


class _BudgetSpent(Exception):
    pass


@dataclass
class SearchPoint:
    """One point of the search: its centre evaluation and the value the search minimised there
    (the centre's J, or the worst of the centre and its stress corners when ``stress_rel`` > 0)."""

    centre: Evaluation
    value: float
    stress: list[Evaluation] = field(default_factory=list)

    @property
    def gains(self) -> dict[str, float]:
        return self.centre.gains


@dataclass
class SearchResult:
    """What a search did: the best point, every proposal (clipped, in gains), the evaluations used."""

    method: str
    budget: int
    seed: int
    stress_rel: float
    best: SearchPoint
    start: SearchPoint
    points: list[SearchPoint] = field(default_factory=list)
    proposals: list[dict[str, float]] = field(default_factory=list)
    n_evaluations: int = 0


def stress_corners(gains: dict[str, float], space: Sequence[GainSpec], rel: float) -> list[dict[str, float]]:
    """The two corners of the ±``rel`` box along the stiffness direction (:attr:`GainSpec.stiff`):
    every stiffening gain up and every damping gain down, and the reverse."""
    out = []
    for sgn in (1.0, -1.0):
        g = dict(gains)
        for s in space:
            g[s.key] = gains[s.key] * (1.0 + sgn * s.stiff * rel)
        out.append(g)
    return out


def search(
    objective: Objective,
    *,
    budget: int = 60,
    method: str = "nelder-mead",
    seed: int = 0,
    x0: dict[str, float] | None = None,
    stress_rel: float = 0.3,
) -> SearchResult:
    """Minimise over the log-gain box with at most ``budget`` search points.

    At each point the search minimises ``max(J(centre), J(stiff corner), J(soft corner))`` of the
    ±``stress_rel`` box (:func:`stress_corners`; ``stress_rel=0``: the centre's J alone), so it is
    steered away from the stability cliff rather than onto it; a point costs 3 evaluations (1 with
    ``stress_rel=0``). ``method``: "nelder-mead" (bounded, from ``x0``, default the shipped gains;
    initial simplex +25 % on each gain) or "de" (differential evolution, Latin-hypercube init, seeded,
    no polish). The start point counts in the budget.
    """
    if budget < 1:
        raise ValueError(f"search: budget: expected >= 1, got {budget}")
    if method not in ("nelder-mead", "de"):
        raise ValueError(f"search: method: expected 'nelder-mead' or 'de', got {method!r}")
    if not (0.0 <= stress_rel < 1.0):
        raise ValueError(f"search: stress_rel: expected a number in [0, 1), got {stress_rel}")
    n0 = len(objective.history)
    proposals: list[dict[str, float]] = []
    points: list[SearchPoint] = []
    seen: dict[tuple, SearchPoint] = {}

    def point(g: dict[str, float]) -> SearchPoint:
        key = objective.memo_key(g)
        if key in seen:
            return seen[key]
        if len(points) >= budget:
            raise _BudgetSpent
        c = objective.evaluate(g)
        st = (
            [objective.evaluate(x) for x in stress_corners(g, objective.space, stress_rel)]
            if stress_rel > 0
            else []
        )
        p = SearchPoint(c, max([c.J] + [e.J for e in st]), st)
        seen[key] = p
        points.append(p)
        return p

    def f(x: np.ndarray) -> float:
        g = objective.to_gains(x)
        proposals.append(g)
        return point(g).value

    start_g = clip_gains(x0 if x0 is not None else default_gains(objective.space), objective.space)
    proposals.append(start_g)
    start = point(start_g)
    bounds = objective.log_bounds
    try:
        if method == "nelder-mead":
            _nelder_mead(f, objective.to_x(start_g), bounds, budget)
        else:
            _differential_evolution(f, objective.to_x(start_g), bounds, budget, seed)
    except _BudgetSpent:
        pass
    best = min(points, key=lambda p: (p.value, p.centre.J))
    return SearchResult(
        method=method,
        budget=budget,
        seed=seed,
        stress_rel=stress_rel,
        best=best,
        start=start,
        points=points,
        proposals=proposals,
        n_evaluations=len(objective.history) - n0,
    )


def _initial_simplex(x_start: np.ndarray, bounds: _Bounds) -> list[np.ndarray]:
    """``x_start`` and, per axis, a vertex 25 % up the gain (down when that leaves the bounds)."""
    simplex = [x_start]
    for i in range(len(x_start)):
        x = x_start.copy()
        lo, hi = bounds[i]
        step = math.log(1.25)
        x[i] = x[i] + step if x[i] + step <= hi else x[i] - step
        x[i] = min(max(x[i], lo), hi)
        simplex.append(x)
    return simplex


def _nelder_mead(f: _Cost, x_start: np.ndarray, bounds: _Bounds, budget: int) -> None:
    simplex = _initial_simplex(x_start, bounds)
    so.minimize(
        f,
        x_start,
        method="Nelder-Mead",
        bounds=bounds,
        options=dict(initial_simplex=np.array(simplex), maxfev=10 * budget, xatol=1e-3, fatol=1e-4),
    )


def _differential_evolution(f: _Cost, x_start: np.ndarray, bounds: _Bounds, budget: int, seed: int) -> None:
    d = len(bounds)
    popsize = max(2, min(8, budget // (3 * d) or 2))
    maxiter = max(1, budget // (popsize * d) - 1)
    so.differential_evolution(
        f,
        bounds,
        popsize=popsize,
        maxiter=maxiter,
        seed=seed,
        polish=False,
        init="latinhypercube",
        tol=0.0,
        updating="immediate",
        x0=x_start,
    )
