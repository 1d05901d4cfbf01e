"""Heat-flux ARMA model: the heat flux through the sensor from the temperature (guiatni eq. 12)::

    Q(t) = -Σ_{i=1..n} c_i·Q(t-i) + Σ_{j=0..m} d_j·T(t-j)

the thermal impedance of whatever the pad touches, as seen by the flux sensor. Like the temperature
model it works in deviation from a reference temperature T_ref_C (°C), so that Q = 0 at rest (pad at
ambient). Identified on the free pad (in air) it predicts the air flux; the estimator of the control
core uses the measured flux, this model is for impedance analysis and for checking the sensor.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from telethermo.ident.narma import MAX_ORDER, _as_1d, solve_scaled_lstsq


def flux_regressors(T_dev: np.ndarray, Q_W: np.ndarray, n: int, m: int) -> tuple[np.ndarray, np.ndarray]:
    """Φ and y of eq. 12 for t = L..N-1 (L = max(n, m)); columns [-Q(t-1..t-n), T(t..t-m)]."""
    T = np.asarray(T_dev, dtype=float)
    Q = np.asarray(Q_W, dtype=float)
    N, L = len(T), max(n, m)
    if len(Q) != N:
        raise ValueError(f"T and Q_W have different lengths ({N} and {len(Q)})")
    if N <= L:
        raise ValueError(f"need more than {L} samples, got {N}")
    cols = [-Q[L - i:N - i] for i in range(1, n + 1)] + [T[L - j:N - j] for j in range(0, m + 1)]
    return np.column_stack(cols), Q[L:].copy()


@dataclass(frozen=True)
class FluxArma:
    """Identified heat-flux ARMA model (eq. 12).

    Attributes:
        c: c_1..c_n (guiatni's sign: Q(t) = -Σ c_i Q(t-i) + ...), dimensionless.
        d: d_0..d_m, W/K.
        period_s: sample period, s.
        T_ref_C: reference temperature, °C (T in eq. 12 is T_C - T_ref_C).
        metrics: fit metrics, W (``rms_one_step_W``, ``free_run_max_W``, ...).
    """

    c: np.ndarray
    d: np.ndarray
    period_s: float
    T_ref_C: float
    metrics: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        c = np.array(self.c, dtype=float).reshape(-1)
        d = np.array(self.d, dtype=float).reshape(-1)
        if not 1 <= c.size <= MAX_ORDER or not 1 <= d.size <= MAX_ORDER + 1:
            raise ValueError(f"FluxArma needs 1..{MAX_ORDER} c and 1..{MAX_ORDER + 1} d coefficients")
        if not (np.all(np.isfinite(c)) and np.all(np.isfinite(d))):
            raise ValueError("FluxArma coefficients must be finite")
        if not (math.isfinite(self.period_s) and self.period_s > 0):
            raise ValueError(f"period_s must be positive, got {self.period_s!r}")
        c.setflags(write=False)
        d.setflags(write=False)
        object.__setattr__(self, "c", c)
        object.__setattr__(self, "d", d)
        object.__setattr__(self, "metrics", dict(self.metrics))

    @property
    def n(self) -> int:
        return int(self.c.size)

    @property
    def m(self) -> int:
        return int(self.d.size - 1)

    def poles(self) -> np.ndarray:
        """Roots of z^n + c_1 z^(n-1) + ... + c_n."""
        return np.roots(np.concatenate([[1.0], self.c]))

    def free_run(self, *, T_C: np.ndarray, Q0_W: float | np.ndarray = 0.0) -> np.ndarray:
        """Heat flux simulated from a temperature record, W (Q fed back from the model's own output).

        ``Q0_W``: the flux at sample 0 (float) or the first samples' fluxes (array); before sample 0 the
        flux is taken equal to the first initial value and T equal to T_C[0].
        """
        from scipy.signal import lfilter, lfiltic

        T = _as_1d("T_C", T_C) - self.T_ref_C
        Q0 = np.atleast_1d(np.asarray(Q0_W, dtype=float))
        if Q0.size < 1 or Q0.size > len(T) or not np.all(np.isfinite(Q0)):
            raise ValueError("Q0_W must be a finite float or an array no longer than T_C")
        a = np.concatenate([[1.0], self.c])
        b = self.d
        k0 = Q0.size
        # initial conditions for lfilter from the past outputs/inputs before sample k0
        L = max(self.n, self.m)
        past_T = np.concatenate([np.full(L, T[0]), T[:k0]])[::-1]
        past_Q = np.concatenate([np.full(L, Q0[0]), Q0])[::-1]
        zi = lfiltic(b, a, past_Q[: self.n], past_T[: self.m] if self.m else [])
        out = np.empty(len(T))
        out[:k0] = Q0
        out[k0:], _ = lfilter(b, a, T[k0:], zi=zi)
        return out

    def predict_one_step(self, *, T_C: np.ndarray, Q_W: np.ndarray) -> np.ndarray:
        """One-step prediction from measured T and Q, W; the first max(n, m) values are NaN."""
        T = _as_1d("T_C", T_C) - self.T_ref_C
        Q = _as_1d("Q_W", Q_W)
        Phi, _ = flux_regressors(T, Q, self.n, self.m)
        out = np.full(len(T), np.nan)
        out[max(self.n, self.m):] = Phi @ np.concatenate([self.c, self.d])
        return out

    def errors(self, *, T_C: np.ndarray, Q_W: np.ndarray, Q_true_W: np.ndarray | None = None,
               warmup: int = 0) -> dict[str, float]:
        """Free-run errors on a record, W: against the measured flux and (if given) the true flux."""
        Q = _as_1d("Q_W", Q_W)
        L = max(self.n, self.m)
        fr = self.free_run(T_C=T_C, Q0_W=Q[:L])
        w = max(L, int(warmup))
        e = (fr - Q)[w:]
        out = {"free_run_max_W": float(np.max(np.abs(e))), "free_run_rms_W": float(np.sqrt(np.mean(e ** 2)))}
        if Q_true_W is not None:
            et = (fr - _as_1d("Q_true_W", Q_true_W))[w:]
            out.update({"free_run_max_vs_true_W": float(np.max(np.abs(et))),
                        "free_run_rms_vs_true_W": float(np.sqrt(np.mean(et ** 2)))})
        return out


def fit_flux_arma(*, T_C: np.ndarray, Q_W: np.ndarray, n: int = 3, m: int = 3, period_s: float = 0.01,
                  T_ref_C: float) -> FluxArma:
    """Fit eq. 12 by least squares on scaled columns; refuse (ValueError) a model with a pole outside
    the unit circle.

    Args:
        T_C: temperatures, °C; Q_W: heat fluxes, W (same length); n, m: orders; period_s: s;
        T_ref_C: reference temperature, °C (the rest temperature, at which Q = 0).
    """
    for name, v, lo in (("n", n, 1), ("m", m, 0)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not lo <= v <= MAX_ORDER:
            raise ValueError(f"flux model order {name} must be an integer in [{lo}, {MAX_ORDER}], got {v!r}")
    T = _as_1d("T_C", T_C)
    Q = _as_1d("Q_W", Q_W)
    if len(T) < max(n, m) + 2 * (n + m + 1):
        raise ValueError(f"need at least {max(n, m) + 2 * (n + m + 1)} samples, got {len(T)}")
    Phi, y = flux_regressors(T - T_ref_C, Q, n, m)
    theta, diag = solve_scaled_lstsq(Phi, y)
    model = FluxArma(c=theta[:n], d=theta[n:], period_s=float(period_s), T_ref_C=float(T_ref_C))
    pmax = float(np.max(np.abs(model.poles())))
    if pmax >= 1.0:
        raise ValueError(f"flux model refused: pole |z| = {pmax:.6f} outside the unit circle")
    resid = y - Phi @ theta
    metrics = {"n_samples": int(len(T)), "rank": diag["rank"], "cond_scaled": diag["cond_scaled"],
               "rms_one_step_W": float(np.sqrt(np.mean(resid ** 2))), "max_pole_modulus": pmax}
    metrics.update({f"train_{k}": v for k, v in model.errors(T_C=T, Q_W=Q).items()})
    object.__setattr__(model, "metrics", metrics)
    return model
