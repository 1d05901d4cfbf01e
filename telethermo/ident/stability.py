"""Stability check of an identified NARMA model: refuse a model a node must not run.

Two tests, both must pass:

1. **Local poles**: at every constant current across the training range (a grid), the model is linear in
   T and its poles (roots of z^n - Σ α_i(I) z^(n-i)) must be strictly inside the unit circle, by at least
   ``pole_margin`` (a pole at 1 would integrate offsets forever).
2. **Bounded free run**: a free run on a long PRBS spanning the training current range (several PRBS
   clock rates, so slow and fast switching are both tried) stays finite and within ``bound_C`` of the
   reference temperature. A time-varying current can destabilise a model whose frozen-current poles are
   all stable; this catches it.

The free run's bound is the larger of 60 °C, 5× the training record's excursion and **twice the model's own
largest steady-state excursion over the current range**. A first-order model stable under switching stays
inside the hull of its steady states (each step is a convex combination of the last temperature and the
steady state of the current held), so a free run beyond twice that hull grows by itself. The last term is
physics, not leniency: a module whose Peltier heat α·I·T outgrows its conductance K at heating currents
(Seebeck ×2.2, R ×4, K ×0.5 in the envelope of issue 22) has a steady state of hundreds of °C at +1 A in
free air, and the simulated plant itself leaves 60 °C on the check's 1 s PRBS (74–89 °C): a fixed 60 °C bound
refused the faithful models of two such modules after three attempts, and their nodes ran the shipped gains.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from telethermo.ident.narma import NarmaModel
from telethermo.ident.prbs import prbs


@dataclass(frozen=True)
class StabilityReport:
    """Verdict of :func:`check_stability`.

    Attributes:
        stable: True if both tests passed.
        reason: why the model is refused ('' if stable).
        max_pole_modulus: largest |z| over the current grid.
        worst_current_A: current at which the largest |z| occurs, A.
        free_run_max_dev_C: largest |T - T_ref| reached in the long free runs, °C (inf if diverged).
        bound_C: the bound the free run had to respect, °C.
        details: further numbers (grid size, PRBS lengths).
    """

    stable: bool
    reason: str
    max_pole_modulus: float
    worst_current_A: float
    free_run_max_dev_C: float
    bound_C: float
    details: dict[str, Any] = field(default_factory=dict)


def check_stability(
    model: NarmaModel,
    *,
    n_grid: int = 201,
    pole_margin: float = 1e-6,
    n_samples: int = 60_000,
    holds: tuple[int, ...] = (1, 10, 100),
    seed: int = 12345,
    bound_C: float | None = None,
) -> StabilityReport:
    """Check that ``model`` is stable (see the module docstring); never raises for an unstable model.

    Args:
        model: the model to check.
        n_grid: number of constant currents across ``model.current_range_A`` for the pole test.
        pole_margin: poles must satisfy |z| <= 1 - pole_margin.
        n_samples: length of each long PRBS free run, samples (split over ``holds``).
        holds: PRBS clock dividers (samples per bit) tried.
        seed: PRBS seed.
        bound_C: allowed |T - T_ref| in the free run, °C. Default: max(60 °C, 5 x the largest deviation
            of the training temperatures from T_ref, 2 x the largest steady-state |T - T_ref| over the
            current grid (computed once the poles pass)).
    """
    lo, hi = model.current_range_A
    grid = np.linspace(lo, hi, n_grid)
    poles = model.local_poles(grid)
    mod = np.abs(poles).max(axis=-1)
    k = int(np.argmax(mod))
    max_mod, worst_I = float(mod[k]), float(grid[k])
    details: dict[str, Any] = {
        "n_grid": n_grid,
        "pole_margin": pole_margin,
        "prbs_holds": list(holds),
        "prbs_samples_each": n_samples // max(len(holds), 1),
    }
    if not np.isfinite(max_mod) or max_mod > 1.0 - pole_margin:
        return StabilityReport(
            False,
            f"local pole |z| = {max_mod:.9f} at I = {worst_I:+.3f} A is not inside the unit "
            f"circle by {pole_margin:g}",
            max_mod,
            worst_I,
            float("nan"),
            math.nan if bound_C is None else bound_C,
            details,
        )
    if bound_C is None:
        steady = float(np.max(np.abs(model.steady_state_C(grid) - model.T_ref_C)))
        details["steady_state_max_dev_C"] = steady
        bound_C = _default_bound_C(model, steady)
    amp = max(abs(lo), abs(hi))
    worst_dev = 0.0
    for idx, hold in enumerate(holds):
        u = prbs(n_samples // max(len(holds), 1), amplitude_A=(0.0, amp), hold_samples=hold, seed=seed + idx)
        T = model.free_run(current_A=u, T0_C=model.T_ref_C)
        if not np.all(np.isfinite(T)):
            return StabilityReport(
                False,
                f"free run on a PRBS (hold {hold} samples) diverged",
                max_mod,
                worst_I,
                float("inf"),
                bound_C,
                details,
            )
        worst_dev = max(worst_dev, float(np.max(np.abs(T - model.T_ref_C))))
        if worst_dev > bound_C:
            return StabilityReport(
                False,
                f"free run on a PRBS (hold {hold} samples) left the bound: |T - T_ref| = "
                f"{worst_dev:.3g} °C > {bound_C:.3g} °C",
                max_mod,
                worst_I,
                worst_dev,
                bound_C,
                details,
            )
    return StabilityReport(True, "", max_mod, worst_I, worst_dev, bound_C, details)


def _default_bound_C(model: NarmaModel, steady_max_dev_C: float) -> float:
    """The free run's default bound, °C (module docstring): max(60, 5 x the training excursion, 2 x
    ``steady_max_dev_C``, the largest steady-state |T - T_ref| over the current grid, finite once the poles
    passed)."""
    dev = max(abs(model.T_range_C[0] - model.T_ref_C), abs(model.T_range_C[1] - model.T_ref_C))
    return max(60.0, 5.0 * dev, 2.0 * steady_max_dev_C)
