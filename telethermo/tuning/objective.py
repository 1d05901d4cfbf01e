"""The tuning objective: J(gains) from offline sessions of the tuning scenes (lower is better).

Each figure comes from :func:`telethermo.offline.figures.compute_figures` of an offline session,
averaged over the scenes::

    J = early_C / 0.5 + tracking_rms_C / 0.1                     (the issue's targets: 2 meets both)
        + late_C / 1 °C                                           (the later phase must not be traded away)
        + limit_per_s · Σ time at any envelope limit (both sides, s)
        + trip · trips + cut_per_s · time with the current cut (s)
        + order_lost (if the rendered material order differs from the direct-touch reference's)
        + margin_per_C · Σ max(0, min(reference margin, 0.7 °C) − rendered margin)
                                                   (consecutive materials, coldest first: discrimination)

A session that yields a non-finite figure (an unstable pair) scores :data:`UNSTABLE_J`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from telethermo.control.gainsfile import GAIN_FIELDS
from telethermo.control.params import default_params
from telethermo.control.types import Role
from telethermo.offline.runner import run_offline_session
from telethermo.tuning.space import DEFAULT_SPACE, GainSpec, clip_gains

UNSTABLE_J = 100.0
MARGIN_GOAL_C = 0.7  # the finger's cold-detection threshold (issue 4)


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

        return {
            "J": self.J,
            "early_C": avg("early_C"),
            "late_C": avg("late_C"),
            "tracking_rms_C": avg("tracking_rms_C"),
            "limit_s": avg("limit_s"),
            "margin_shortfall_C": avg("margin_shortfall_C"),
            "trips": int(sum(s["trips"] for s in self.scenes)),
            "order_kept": all(s["order_kept"] for s in self.scenes),
        }


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
    used = {
        "early_C": early,
        "late_C": late,
        "tracking_rms_C": trk,
        "limit_s": limit_s,
        "cut_s": cut_s,
        "trips": trips,
        "order_kept": order,
        "margin_shortfall_C": shortfall,
        "margins_C": [_finite(m) for m in disc.get("margins_C") or []],
        "per_contact_early_C": [_finite(p["early_T"]["mean_abs"]) for p in tr.get("per_contact", [])],
    }
    if not (math.isfinite(early) and math.isfinite(trk)):
        return UNSTABLE_J, used
    J = (
        weights.early_per_C * early
        + weights.late_per_C * (late if math.isfinite(late) else 0.0)
        + weights.tracking_per_C * trk
        + weights.limit_per_s * limit_s
        + weights.trip * trips
        + weights.cut_per_s * cut_s
        + (0.0 if order else weights.order_lost)
        + weights.margin_per_C * shortfall
    )
    return float(min(J, UNSTABLE_J)), used


class Objective:
    """J(gains) over ``scenes`` (see the module docstring); memoised, with a history of every evaluation.

    ``gains`` are dicts ``{"master.kp_A_per_C": ..., ...}`` (keys of ``space``; unknown keys refused);
    gains not given keep the shipped defaults. ``__call__(x)`` takes log-gains (the search's space).
    """

    def __init__(
        self,
        scenes: Sequence[Any],
        *,
        space: Sequence[GainSpec] = DEFAULT_SPACE,
        weights: Weights = Weights(),
        seed: int = 0,
        duration_s: float | None = None,
        progress: Callable[[Evaluation, int], None] | None = None,
    ) -> None:
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
                raise ValueError(
                    f"Objective: unknown gain {k!r} (expected role.field, field in {GAIN_FIELDS})"
                )
            over[role][name] = float(v)
        return (
            default_params(Role.MASTER, period_s=period_s, **over["master"]),
            default_params(Role.SLAVE, period_s=period_s, **over["slave"]),
        )

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
        gains = {k: float(v) for k, v in gains.items()}
        key = self.memo_key(gains)
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        Js, per = [], []
        for sc in self.scenes:
            pm, ps = self.params(gains, sc.period_s)
            try:
                res = run_offline_session(
                    sc, master_params=pm, slave_params=ps, seed=self.seed, duration_s=self.duration_s
                )
                J, used = score_figures(res.figures, self.weights)
            except (FloatingPointError, np.linalg.LinAlgError, OverflowError) as exc:
                J, used = (
                    UNSTABLE_J,
                    {
                        "early_C": math.nan,
                        "late_C": math.nan,
                        "tracking_rms_C": math.nan,
                        "limit_s": math.nan,
                        "cut_s": math.nan,
                        "trips": 0,
                        "order_kept": False,
                        "margin_shortfall_C": math.nan,
                        "margins_C": [],
                        "per_contact_early_C": [],
                        "error": repr(exc),
                    },
                )
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
