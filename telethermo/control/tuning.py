"""Gain tuning of the bilateral pair: an objective built on offline sessions, a bounded search, a robustness check.

    from telethermo.control.tuning import Objective, tuning_scenes, tune
    obj = Objective(tuning_scenes("probe_touches_al_steel_wood"))      # nominal + a perturbed variant
    res = tune(obj, budget=60, method="nelder-mead", seed=0)           # search, then robust selection
    res.best.gains        # {"master.kp_A_per_C": ..., ...}
    gains_document(res)   # the gains file (see load_gains / docs/tuning.md)

**Objective** (lower is better; each figure from :func:`telethermo.session.figures.compute_figures` of
an offline session, averaged over the scenes)::

    J = early_C / 0.5 + tracking_rms_C / 0.1                     (the issue's targets: 2 meets both)
        + late_C / 1 °C                                           (the later phase must not be traded away)
        + limit_per_s · Σ time at any envelope limit (both sides, s)
        + trip · trips + cut_per_s · time with the current cut (s)
        + order_lost (if the rendered material order differs from the direct-touch reference's)
        + margin_per_C · Σ max(0, min(reference margin, 0.7 °C) − rendered margin)
                                                   (consecutive materials, coldest first: discrimination)

A session that yields a non-finite figure (an unstable pair) scores :data:`UNSTABLE_J`.

**Search space**: the log of each gain in :data:`DEFAULT_SPACE` (bounds in A/°C, A/(°C·s), A/W; kQ and
kiQ stay at 0: a screening found every non-zero value worse, docs/tuning.md). Every point the optimiser
proposes is clipped to the bounds *before* a session runs (and recorded: tests check that none leaves
them). The search minimises the worst of a point and its two *stress corners* (:func:`stress_corners`),
which keeps it off the stability cliff.

**Robust selection**: the best few distinct points of the search and the reference (the shipped gains)
are checked at ±``rel`` (30 %) on each gain, one at a time, plus a few seeded random corners of the
±``rel`` box; among the points whose centre is no worse than the reference's, the one with the best
*worst case* wins (ties broken by the centre value).

Pure: no wall clock, no files (except :func:`write_gains` / :func:`load_gains`), deterministic for
a seed (the sessions' sensor noise is seeded, the optimisers are seeded).
"""
from __future__ import annotations

import dataclasses
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from telethermo.control.defaults import GAINS
from telethermo.control.params import default_params
from telethermo.control.types import Role

GAINS_FORMAT = "telethermo.gains/1"
UNSTABLE_J = 100.0
MARGIN_GOAL_C = 0.7  # the finger's cold-detection threshold (issue 4)
#: the gains the tuner may change (CoreParams field names)
GAIN_FIELDS = ("kp_A_per_C", "ki_A_per_C_s", "kQ_A_per_W", "kpQ_A_per_W", "kiQ_A_per_W_s")


@dataclass(frozen=True)
class GainSpec:
    """One searched gain: ``role`` ("master"/"slave"), CoreParams ``name``, bounds ``lo`` < ``hi`` (> 0)."""

    role: str
    name: str
    lo: float
    hi: float
    stiff: int = 1  # +1: raising it stiffens the loop (PI gains); -1: it damps (the flux-mirror loop)

    def __post_init__(self) -> None:
        if self.role not in ("master", "slave"):
            raise ValueError(f"GainSpec.role: expected 'master' or 'slave', got {self.role!r}")
        if self.name not in GAIN_FIELDS:
            raise ValueError(f"GainSpec.name: expected one of {GAIN_FIELDS}, got {self.name!r}")
        if self.stiff not in (1, -1):
            raise ValueError(f"GainSpec.stiff: expected +1 or -1, got {self.stiff!r}")
        if not (0 < self.lo < self.hi and math.isfinite(self.hi)):
            raise ValueError(f"GainSpec {self.key}: expected 0 < lo < hi, got [{self.lo}, {self.hi}]")

    @property
    def key(self) -> str:
        return f"{self.role}.{self.name}"


#: the default search space: the gains that matter on the guiatni §5.3 scene (docs/tuning.md, screening)
DEFAULT_SPACE: tuple[GainSpec, ...] = (
    GainSpec("master", "kp_A_per_C", 0.1, 5.0),
    GainSpec("master", "ki_A_per_C_s", 0.01, 2.0),
    GainSpec("master", "kpQ_A_per_W", 0.01, 2.0, stiff=-1),
    GainSpec("slave", "kp_A_per_C", 0.05, 5.0),
    GainSpec("slave", "ki_A_per_C_s", 0.01, 2.0),
    GainSpec("slave", "kpQ_A_per_W", 0.005, 1.0, stiff=-1),
)


@dataclass(frozen=True)
class Weights:
    """Weights of the objective (see the module docstring)."""

    early_per_C: float = 1.0 / 0.5
    late_per_C: float = 1.0
    tracking_per_C: float = 1.0 / 0.1
    limit_per_s: float = 0.05
    trip: float = 5.0
    cut_per_s: float = 1.0
    order_lost: float = 1.0
    margin_per_C: float = 2.0


# --------------------------------------------------------------------------------------------- scenes

def perturbed_scene(scene: Any) -> Any:
    """A robustness variant of a telepresence scene: another room, another operator, other objects.

    Ambient 3 °C cooler (22 °C for the guiatni scene; objects start there), a finger with a 4/3 thicker
    epidermis (0.8 mm), 1.5× dermal perfusion and a core at most 36.5 °C, the probe pressing at most 5 N
    (contact resistance no longer zero) and the finger at most 6 N, objects of neighbouring materials
    (aluminium→copper, carbon steel→stainless steel, oak→PVC, ...) touched in a rotated order. Same
    timing as the original. (The scene's noise seed is changed too, but an offline session seeds the
    noise from its own ``seed`` argument: :class:`Objective` passes its ``seed`` to every scene.)
    """
    import sim
    from sim.bodies import FingerParams

    sc = sim.load_scene(scene) if isinstance(scene, (str, os.PathLike)) else scene
    swap = {"aluminium": "copper", "carbon_steel": "stainless_steel", "oak": "pvc", "copper": "aluminium",
            "stainless_steel": "carbon_steel", "pvc": "oak", "brass": "aluminium", "eps": "oak", "glass": "ceramic"}
    ambient = sc.ambient_C - 3.0
    objects = {k: dataclasses.replace(o, material=swap.get(o.material, o.material), T0_C=ambient)
               for k, o in sc.objects.items()}
    f = sc.finger
    layers = list(f.layers)
    if layers:
        m, t, w = layers[0]
        layers[0] = (m, t * 4.0 / 3.0, w)
    if len(layers) > 1:
        m, t, w = layers[1]
        layers[1] = (m, t, w * 1.5)
    finger = FingerParams(layers=tuple(layers), T_blood_C=f.T_blood_C, core_C=min(f.core_C, 36.5))
    names = [t.body for t in sc.slave_contacts]
    rot = names[1:] + names[:1] if names else names
    slave = tuple(dataclasses.replace(t, body=b, force_N=min(t.force_N, 5.0)) for t, b in zip(sc.slave_contacts, rot))
    master = tuple(dataclasses.replace(t, force_N=min(t.force_N, 6.0)) for t in sc.master_contacts)
    return dataclasses.replace(sc, name=f"{sc.name}~perturbed", ambient_C=ambient, objects=objects, finger=finger,
                               slave_contacts=slave, master_contacts=master,
                               seed=(sc.seed or 0) + 100)


def tuning_scenes(scene: Any, *, perturbed: bool = True) -> list[Any]:
    """The scenes an objective averages over: ``scene`` and (default) its :func:`perturbed_scene`."""
    import sim
    sc = sim.load_scene(scene) if isinstance(scene, (str, os.PathLike)) else scene
    if sc.kind != "telepresence":
        raise ValueError(f"tuning: scene {sc.name!r} is {sc.kind!r}; the bilateral gains need a telepresence scene")
    return [sc, perturbed_scene(sc)] if perturbed else [sc]


# --------------------------------------------------------------------------------------------- objective

def default_gains(space: Sequence[GainSpec] = DEFAULT_SPACE) -> dict[str, float]:
    """The shipped defaults (telethermo.control.defaults.GAINS) of the gains in ``space``."""
    return {s.key: float(GAINS[Role(s.role)][s.name]) for s in space}


def clip_gains(gains: dict[str, float], space: Sequence[GainSpec]) -> dict[str, float]:
    """``gains`` with every searched gain clipped to its bounds (other keys untouched)."""
    out = dict(gains)
    for s in space:
        if s.key in out:
            out[s.key] = float(min(max(out[s.key], s.lo), s.hi))
    return out


@dataclass
class Evaluation:
    """The objective at one gain set."""

    gains: dict[str, float]
    J: float
    scenes: list[dict[str, Any]]

    def summary(self) -> dict[str, Any]:
        """Scene-averaged figures: early/late/tracking errors, limit time, trips, order kept everywhere."""
        def avg(k: str) -> float:
            v = [s[k] for s in self.scenes]
            return float(np.mean(v)) if all(math.isfinite(x) for x in v) else math.nan
        return {"J": self.J, "early_C": avg("early_C"), "late_C": avg("late_C"), "tracking_rms_C": avg("tracking_rms_C"),
                "limit_s": avg("limit_s"), "margin_shortfall_C": avg("margin_shortfall_C"), "trips": int(sum(s["trips"] for s in self.scenes)),
                "order_kept": all(s["order_kept"] for s in self.scenes)}


def _finite(x: Any) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return math.nan
    return v if math.isfinite(v) else math.nan


def score_figures(figures: dict[str, Any], weights: Weights = Weights()) -> tuple[float, dict[str, Any]]:
    """(J of one session, the figures it used) from :func:`compute_figures`'s dict."""
    tr = figures.get("transparency", {})
    early, late = _finite(tr.get("early_mean_error_C")), _finite(tr.get("late_mean_error_C"))
    trk = _finite(figures.get("tracking", {}).get("rms_C"))
    saf = figures.get("safety", {})
    limit_s = float(sum(sum(v.values()) for v in saf.get("time_at_limit_s", {}).values()))
    cut_s = float(sum(saf.get("time_cut_s", {}).values()))
    trips = int(saf.get("n_trips", 0))
    disc = figures.get("discrimination", {})
    order = bool(disc.get("order_kept", False))
    # discrimination: each consecutive margin should reach min(reference margin, 0.7 °C threshold)
    shortfall = 0.0
    for m, r in zip(disc.get("margins_C") or [], disc.get("reference_margins_C") or []):
        m, r = _finite(m), _finite(r)
        if math.isfinite(m) and math.isfinite(r):
            shortfall += max(0.0, min(r, MARGIN_GOAL_C) - m)
    used = {"early_C": early, "late_C": late, "tracking_rms_C": trk, "limit_s": limit_s, "cut_s": cut_s,
            "trips": trips, "order_kept": order,
            "margin_shortfall_C": shortfall, "margins_C": [_finite(m) for m in disc.get("margins_C") or []],
            "per_contact_early_C": [_finite(p["early_T"]["mean_abs"]) for p in tr.get("per_contact", [])]}
    if not (math.isfinite(early) and math.isfinite(trk)):
        return UNSTABLE_J, used
    J = (weights.early_per_C * early + weights.late_per_C * (late if math.isfinite(late) else 0.0)
         + weights.tracking_per_C * trk + weights.limit_per_s * limit_s
         + weights.trip * trips + weights.cut_per_s * cut_s + (0.0 if order else weights.order_lost)
         + weights.margin_per_C * shortfall)
    return float(min(J, UNSTABLE_J)), used


class Objective:
    """J(gains) over ``scenes`` (see the module docstring); memoised, with a history of every evaluation.

    ``gains`` are dicts ``{"master.kp_A_per_C": ..., ...}`` (keys of ``space``; unknown keys refused);
    gains not given keep the shipped defaults. ``__call__(x)`` takes log-gains (the search's space).
    """

    def __init__(self, scenes: Sequence[Any], *, space: Sequence[GainSpec] = DEFAULT_SPACE,
                 weights: Weights = Weights(), seed: int = 0, duration_s: float | None = None,
                 progress: Callable[[Evaluation, int], None] | None = None) -> None:
        if not scenes:
            raise ValueError("Objective: expected at least one scene")
        self.scenes = list(scenes)
        self.space = tuple(space)
        keys = [s.key for s in self.space]
        if len(set(keys)) != len(keys):
            raise ValueError(f"Objective: duplicate gains in the space: {keys}")
        self.weights = weights
        self.seed = int(seed)
        self.duration_s = duration_s
        self.progress = progress
        self.history: list[Evaluation] = []
        self._cache: dict[tuple, Evaluation] = {}
        self.n_sessions = 0

    @property
    def keys(self) -> list[str]:
        return [s.key for s in self.space]

    def params(self, gains: dict[str, float], period_s: float):
        """(master, slave) CoreParams: the defaults at ``period_s`` with ``gains`` applied."""
        over: dict[str, dict[str, float]] = {"master": {}, "slave": {}}
        for k, v in gains.items():
            role, _, name = k.partition(".")
            if role not in over or name not in GAIN_FIELDS:
                raise ValueError(f"Objective: unknown gain {k!r} (expected role.field, field in {GAIN_FIELDS})")
            over[role][name] = float(v)
        return (default_params(Role.MASTER, period_s=period_s, **over["master"]),
                default_params(Role.SLAVE, period_s=period_s, **over["slave"]))

    def to_gains(self, x: Sequence[float]) -> dict[str, float]:
        """Log-gains -> gains rounded to 4 significant digits, clipped to the bounds."""
        x = np.asarray(x, float)
        if x.shape != (len(self.space),):
            raise ValueError(f"Objective: expected {len(self.space)} log-gains, got shape {x.shape}")
        # 4 significant digits: readable gains files, and the memo catches near-repeats
        return clip_gains({s.key: float(f"{math.exp(v):.4g}") for s, v in zip(self.space, x)}, self.space)

    def to_x(self, gains: dict[str, float]) -> np.ndarray:
        g = clip_gains(gains, self.space)
        return np.array([math.log(g[s.key]) for s in self.space])

    @property
    def log_bounds(self) -> list[tuple[float, float]]:
        return [(math.log(s.lo), math.log(s.hi)) for s in self.space]

    @staticmethod
    def memo_key(gains: dict[str, float]) -> tuple:
        """The memo's key of a gain set (values to 12 significant digits)."""
        return tuple(sorted((k, float(f"{float(v):.12g}")) for k, v in gains.items()))

    def is_cached(self, gains: dict[str, float]) -> bool:
        return self.memo_key(gains) in self._cache

    def evaluate(self, gains: dict[str, float]) -> Evaluation:
        """J at ``gains`` (memoised on the gains rounded to 12 significant digits)."""
        from telethermo.session.runner import run_offline_session

        gains = {k: float(v) for k, v in gains.items()}
        key = self.memo_key(gains)
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        Js, per = [], []
        for sc in self.scenes:
            pm, ps = self.params(gains, sc.period_s)
            try:
                res = run_offline_session(sc, master_params=pm, slave_params=ps, seed=self.seed,
                                          duration_s=self.duration_s)
                J, used = score_figures(res.figures, self.weights)
            except (FloatingPointError, np.linalg.LinAlgError, OverflowError) as exc:
                J, used = UNSTABLE_J, {"early_C": math.nan, "late_C": math.nan, "tracking_rms_C": math.nan,
                                       "limit_s": math.nan, "cut_s": math.nan, "trips": 0, "order_kept": False,
                                       "margin_shortfall_C": math.nan, "margins_C": [],
                                       "per_contact_early_C": [], "error": repr(exc)}
            self.n_sessions += 1
            Js.append(J)
            per.append(dict(scene=sc.name, J=J, **used))
        ev = Evaluation(gains=gains, J=float(np.mean(Js)), scenes=per)
        self._cache[key] = ev
        self.history.append(ev)
        if self.progress is not None:
            self.progress(ev, len(self.history))
        return ev

    def __call__(self, x: Sequence[float]) -> float:
        return self.evaluate(self.to_gains(x)).J


# --------------------------------------------------------------------------------------------- search

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


def search(objective: Objective, *, budget: int = 60, method: str = "nelder-mead", seed: int = 0,
           x0: dict[str, float] | None = None, stress_rel: float = 0.3) -> SearchResult:
    """Minimise over the log-gain box with at most ``budget`` search points.

    At each point the search minimises ``max(J(centre), J(stiff corner), J(soft corner))`` of the
    ±``stress_rel`` box (:func:`stress_corners`; ``stress_rel=0``: the centre's J alone), so it is
    steered away from the stability cliff rather than onto it; a point costs 3 evaluations (1 with
    ``stress_rel=0``). ``method``: "nelder-mead" (bounded, from ``x0``, default the shipped gains;
    initial simplex +25 % on each gain) or "de" (differential evolution, Latin-hypercube init, seeded,
    no polish). The start point counts in the budget.
    """
    import scipy.optimize as so

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
        st = [objective.evaluate(x) for x in stress_corners(g, objective.space, stress_rel)] if stress_rel > 0 else []
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
    d = len(objective.space)
    try:
        if method == "nelder-mead":
            x_start = objective.to_x(start_g)
            simplex = [x_start]
            for i in range(d):
                x = x_start.copy()
                lo, hi = bounds[i]
                step = math.log(1.25)
                x[i] = x[i] + step if x[i] + step <= hi else x[i] - step
                x[i] = min(max(x[i], lo), hi)
                simplex.append(x)
            so.minimize(f, x_start, method="Nelder-Mead", bounds=bounds,
                        options=dict(initial_simplex=np.array(simplex), maxfev=10 * budget, xatol=1e-3, fatol=1e-4))
        else:
            popsize = max(2, min(8, budget // (3 * d) or 2))
            maxiter = max(1, budget // (popsize * d) - 1)
            so.differential_evolution(f, bounds, popsize=popsize, maxiter=maxiter, seed=seed, polish=False,
                                      init="latinhypercube", tol=0.0, updating="immediate", x0=objective.to_x(start_g))
    except _BudgetSpent:
        pass
    best = min(points, key=lambda p: (p.value, p.centre.J))
    return SearchResult(method=method, budget=budget, seed=seed, stress_rel=stress_rel, best=best, start=start,
                        points=points, proposals=proposals, n_evaluations=len(objective.history) - n0)


# --------------------------------------------------------------------------------------------- robustness

def box_points(gains: dict[str, float], space: Sequence[GainSpec], *, rel: float = 0.3, corners: int = 4,
               seed: int = 0) -> list[tuple[str, dict[str, float]]]:
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


def robustness(objective: Objective, gains: dict[str, float], *, rel: float = 0.3, corners: int = 4,
               seed: int = 0) -> Robustness:
    """Evaluate ``gains`` and its ±``rel`` box (:func:`box_points`)."""
    centre = objective.evaluate(gains)
    rows = [(lab, objective.evaluate(g)) for lab, g in box_points(gains, objective.space, rel=rel, corners=corners,
                                                                   seed=seed)]
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


def distinct_best(points: Sequence[SearchPoint], space: Sequence[GainSpec], k: int, *,
                  min_log_distance: float = 0.1) -> list[SearchPoint]:
    """The ``k`` best search points (by the searched value) whose log-gains differ by more than
    ``min_log_distance`` (max norm)."""
    out: list[SearchPoint] = []
    for p in sorted(points, key=lambda p: (p.value, p.centre.J)):
        if p.value >= UNSTABLE_J:
            break
        x = np.array([math.log(p.gains[s.key]) for s in space])
        if all(np.max(np.abs(x - np.array([math.log(o.gains[s.key]) for s in space]))) > min_log_distance for o in out):
            out.append(p)
        if len(out) >= k:
            break
    return out


def tune(objective: Objective, *, budget: int = 60, method: str = "nelder-mead", seed: int = 0,
         candidates: int = 3, rel: float = 0.3, corners: int = 4, stress_rel: float | None = None,
         x0: dict[str, float] | None = None, reference: dict[str, float] | None = None,
         on_stage: Callable[[str], None] | None = None) -> TuneResult:
    """Search (``budget`` points, stress corners at ``stress_rel``, default ``rel``), then check the
    best ``candidates`` distinct points and the ``reference`` (default: the shipped gains) over the
    ±``rel`` box (:func:`robustness`) and choose the best worst case (ties: the best centre) among
    those whose centre is no worse than the reference's (so the reference wins if none is)."""
    say = on_stage or (lambda _m: None)
    stress_rel = rel if stress_rel is None else stress_rel
    say(f"search: {method}, budget {budget} points, {len(objective.space)} gains, {len(objective.scenes)} scenes, "
        f"stress corners ±{stress_rel:.0%}")
    sr = search(objective, budget=budget, method=method, seed=seed, x0=x0, stress_rel=stress_rel)
    cands = distinct_best(sr.points, objective.space, candidates)
    ref_g = clip_gains(reference if reference is not None else default_gains(objective.space), objective.space)
    robs: list[Robustness] = []
    for i, p in enumerate(cands):
        say(f"robustness of candidate {i + 1}/{len(cands)} (J = {p.centre.J:.3f}, searched value {p.value:.3f})")
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


# --------------------------------------------------------------------------------------------- gains file

def gains_document(result: TuneResult, objective: Objective, *, extra: dict[str, Any] | None = None) -> dict[str, Any]:
    """The gains file (format :data:`GAINS_FORMAT`, see docs/tuning.md) of a tuning run."""
    g = result.best.gains
    per_role: dict[str, dict[str, float]] = {"master": {}, "slave": {}}
    for role in per_role:
        for name in GAIN_FIELDS:  # every gain, searched or default, so the file is complete
            per_role[role][name] = float(g.get(f"{role}.{name}", GAINS[Role(role)][name]))
    doc = {"format": GAINS_FORMAT, "period_s": float(objective.scenes[0].period_s),
           "master": per_role["master"], "slave": per_role["slave"],
           "objective": {"J": result.best.J, "worst_J_over_box": result.chosen.worst.J, "rel_box": result.rel,
                         "scenes": [s.name for s in objective.scenes], "seed": objective.seed,
                         "weights": dataclasses.asdict(objective.weights)},
           "search": {"method": result.search.method, "budget_points": result.search.budget,
                      "seed": result.search.seed, "stress_rel": result.search.stress_rel,
                      "evaluations": result.search.n_evaluations}}
    if extra:
        doc.update(extra)
    return doc


def parse_gains(doc: Any, where: str = "gains") -> dict[Role, dict[str, float]]:
    """Validate a gains document -> {Role: {CoreParams field: value}} (the overrides of default_params)."""
    if not isinstance(doc, dict) or doc.get("format") != GAINS_FORMAT:
        raise ValueError(f"{where}: expected a JSON object with \"format\": \"{GAINS_FORMAT}\"")
    out: dict[Role, dict[str, float]] = {}
    for role in (Role.MASTER, Role.SLAVE):
        r = doc.get(role.value)
        if not isinstance(r, dict):
            raise ValueError(f"{where}: {role.value}: expected an object of gains")
        vals: dict[str, float] = {}
        for k, v in r.items():
            if k not in GAIN_FIELDS:
                raise ValueError(f"{where}: {role.value}.{k}: unknown gain (expected one of {', '.join(GAIN_FIELDS)})")
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ValueError(f"{where}: {role.value}.{k}: expected a finite number, got {v!r}")
            vals[k] = float(v)
        default_params(role, **vals)  # CoreParams validates the ranges (ValueError names the field)
        out[role] = vals
    return out


def load_gains(path: str | os.PathLike) -> dict[Role, dict[str, float]]:
    """Read a gains file: ``default_params(role, **load_gains(path)[role])`` gives the tuned parameters."""
    p = Path(path)
    try:
        doc = json.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ValueError(f"{p}: no such gains file") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"{p}: not a JSON gains file ({exc})") from None
    return parse_gains(doc, str(p))


def write_gains(path: str | os.PathLike, doc: dict[str, Any]) -> Path:
    """Write a gains document atomically (validated first)."""
    from telethermo.atomic import write_json_atomic
    parse_gains(doc, str(path))
    return write_json_atomic(path, doc)
