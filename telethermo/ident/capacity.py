"""Steady-state heating/cooling capacity model of a TEM (guiatni eq. 13-16)::

    P = θ1·T·I + θ2·I² + θ3·T + θ4·I + θ5 = θᵀφ,   φ = [T·I, I², T, I, 1]

P is the heat the TEM delivers at one plate (W) at steady state, T that plate's temperature (°C), I the
drive current (A). Eq. 5/6 give this form with T_h - T_c folded into θ3, θ5 (the other plate held by
the heat sink). On our rigs we model the **pad plate**: P = heat out of the pad into its load (the
rig's Q_W sign: > 0 when the pad heats what it touches), so for I > 0 it is the heating capacity and for
I < 0 minus the cooling capacity; eq. 5 and 6 are the same polynomial once the current's sign is kept.
Fitted by least squares (eq. 15/16, by pivoted QR on scaled columns, not the normal equations) from N
steady-state points.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

from telethermo.ident.narma import _as_1d, solve_scaled_lstsq


def capacity_regressors(current_A: np.ndarray, T_C: np.ndarray) -> np.ndarray:
    """φ rows [T·I, I², T, I, 1] (eq. 13), shape (N, 5)."""
    I = np.asarray(current_A, dtype=float)
    T = np.asarray(T_C, dtype=float)
    return np.column_stack([T * I, I * I, T, I, np.ones_like(I)])


@dataclass(frozen=True)
class CapacityModel:
    """Identified steady-state capacity model (eq. 13) of the pad plate.

    Attributes:
        theta: θ1..θ5 (W/(°C·A), W/A², W/°C, W/A, W).
        current_range_A: (min, max) current of the steady-state points, A.
        metrics: fit metrics (``rms_W``, ``max_abs_W``, ``n_points``, ``rank``).
    """

    theta: np.ndarray
    current_range_A: tuple[float, float]
    metrics: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        th = np.array(self.theta, dtype=float).reshape(-1)
        if th.size != 5 or not np.all(np.isfinite(th)):
            raise ValueError("CapacityModel.theta must be 5 finite numbers")
        th.setflags(write=False)
        object.__setattr__(self, "theta", th)
        lo, hi = (float(v) for v in self.current_range_A)
        if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
            raise ValueError(f"current_range_A must be (min, max), got {self.current_range_A!r}")
        object.__setattr__(self, "current_range_A", (lo, hi))
        object.__setattr__(self, "metrics", dict(self.metrics))

    def predict(self, *, current_A: np.ndarray | float, T_C: np.ndarray | float) -> np.ndarray:
        """Steady-state heat out of the pad, W, at current ``current_A`` (A) and pad temperature
        ``T_C`` (°C)."""
        I = np.asarray(current_A, dtype=float)
        T = np.asarray(T_C, dtype=float)
        X = capacity_regressors(np.ravel(I), np.ravel(np.broadcast_to(T, I.shape)))
        return cast(np.ndarray, X.dot(self.theta).reshape(I.shape))


def fit_capacity(*, current_A: np.ndarray, T_C: np.ndarray, P_W: np.ndarray) -> CapacityModel:
    """Fit eq. 13 by least squares (eq. 15) on scaled columns from N >= 5 steady-state points.

    Args:
        current_A: currents of the steady states, A.
        T_C: pad temperatures at steady state, °C.
        P_W: heat out of the pad at steady state, W.
    """
    I = _as_1d("current_A", current_A)
    T = _as_1d("T_C", T_C)
    P = _as_1d("P_W", P_W)
    if not len(I) == len(T) == len(P):
        raise ValueError(f"current_A, T_C, P_W must have equal lengths ({len(I)}, {len(T)}, {len(P)})")
    if len(I) < 5:
        raise ValueError(f"need at least 5 steady-state points for 5 parameters, got {len(I)}")
    Phi = capacity_regressors(I, T)
    theta, diag = solve_scaled_lstsq(Phi, P)
    resid = P - Phi @ theta
    return CapacityModel(
        theta=theta,
        current_range_A=(float(I.min()), float(I.max())),
        metrics={
            "n_points": int(len(I)),
            "rank": diag["rank"],
            "cond_scaled": diag["cond_scaled"],
            "rms_W": float(np.sqrt(np.mean(resid**2))),
            "max_abs_W": float(np.max(np.abs(resid))),
        },
    )
