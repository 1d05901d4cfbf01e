"""Heat-flux ARMA model: the heat flux through the sensor from the temperature (guiatni eq. 12),
optionally extended with the drive current::

    Q(t) = -Σ_{i=1..n} c_i·Q(t-i) + Σ_{j=0..m} d_j·T(t-j)
           [ + Σ_{j=1..m} (e_j·I(t-j) + g_j·I(t-j)² + h_j·I(t-j)·T(t-j)) ]

The bracket is our extension: the Peltier (α·T·I), Joule (R·I²) and current-proportional heats of eq. 5/6
entering the pad plate. On a pad the flux through the sensor *leads* its mid-plane temperature (heat
enters the sensor's bottom face before the mid-plane warms), so a model causal in T alone has an error
floor; the current, the cause of both, removes it (measured on the default simulated rig, held-out worst
case: 0.057 W from T alone, 0.010 W with I and I², 0.003 W with I, I² and I·T, at the sensor noise
floor; see docs/identification.md). Without current terms it is guiatni's eq. 12 exactly.

Like the temperature model it works in deviation from a reference temperature T_ref_C (°C), so that
Q = 0 at rest. Fitted by **output error** (the free-run flux error, Levenberg-Marquardt from a FIR
least-squares start, every trial model stable), not by equation error: with noise on both T and Q
the equation-error LS gives biased, even unstable, models (it did on the simulated rig).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np
import scipy.optimize
import scipy.signal

from telethermo.ident.narma import MAX_ORDER, _as_1d


@dataclass(frozen=True)
class FluxArma:
    """Identified heat-flux model (eq. 12, optionally with current terms).

    Attributes:
        c: c_1..c_n (guiatni's sign: Q(t) = -Σ c_i Q(t-i) + ...), dimensionless.
        d: d_0..d_m, W/K.
        period_s: sample period, s.
        T_ref_C: reference temperature, °C (T in eq. 12 is T_C - T_ref_C).
        e: e_1..e_m, W/A (empty: no current terms).
        g: g_1..g_m, W/A² (empty: no current terms).
        h: h_1..h_m, W/(A·K) (empty: no current terms).
        metrics: fit metrics, W.
    """

    c: np.ndarray
    d: np.ndarray
    period_s: float
    T_ref_C: float
    e: np.ndarray = field(default_factory=lambda: np.zeros(0))
    g: np.ndarray = field(default_factory=lambda: np.zeros(0))
    h: np.ndarray = field(default_factory=lambda: np.zeros(0))
    metrics: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        arrs = {k: np.array(getattr(self, k), dtype=float).reshape(-1) for k in ("c", "d", "e", "g", "h")}
        if not 1 <= arrs["c"].size <= MAX_ORDER or not 1 <= arrs["d"].size <= MAX_ORDER + 1:
            raise ValueError(f"FluxArma needs 1..{MAX_ORDER} c and 1..{MAX_ORDER + 1} d coefficients")
        if not arrs["e"].size == arrs["g"].size == arrs["h"].size or arrs["e"].size not in (
            0,
            arrs["d"].size - 1,
        ):
            raise ValueError("FluxArma current terms e, g, h must all be empty or have m = len(d) - 1 values")
        if not all(np.all(np.isfinite(a)) for a in arrs.values()):
            raise ValueError("FluxArma coefficients must be finite")
        if not (math.isfinite(self.period_s) and self.period_s > 0):
            raise ValueError(f"period_s must be positive, got {self.period_s!r}")
        if not math.isfinite(self.T_ref_C):
            raise ValueError(f"T_ref_C must be finite, got {self.T_ref_C!r}")
        for k, a in arrs.items():
            a.setflags(write=False)
            object.__setattr__(self, k, a)
        object.__setattr__(self, "metrics", dict(self.metrics))

    @property
    def n(self) -> int:
        return int(self.c.size)

    @property
    def m(self) -> int:
        return int(self.d.size - 1)

    @property
    def with_current(self) -> bool:
        return self.e.size > 0

    def poles(self) -> np.ndarray:
        """Roots of z^n + c_1 z^(n-1) + ... + c_n."""
        return np.roots(np.concatenate([[1.0], self.c]))

    def free_run(self, *, T_C: np.ndarray, current_A: np.ndarray | None = None) -> np.ndarray:
        """Heat flux simulated from a temperature record (and the currents, if the model has current
        terms), W; the model starts at rest (Q = 0, T = T_ref, I = 0 before sample 0).
        ``current_A[k]`` is held from sample k to k+1, as everywhere in telethermo.ident."""
        T = _as_1d("T_C", T_C) - self.T_ref_C
        a = np.concatenate([[1.0], self.c])
        out = scipy.signal.lfilter(self.d, a, T)
        if self.with_current:
            if current_A is None:
                raise ValueError("this flux model has current terms: pass current_A")
            I = _as_1d("current_A", current_A)
            if len(I) != len(T):
                raise ValueError(f"T_C and current_A have different lengths ({len(T)} and {len(I)})")
            out += scipy.signal.lfilter(np.concatenate([[0.0], self.e]), a, I)
            out += scipy.signal.lfilter(np.concatenate([[0.0], self.g]), a, I * I)
            out += scipy.signal.lfilter(np.concatenate([[0.0], self.h]), a, I * T)
        return cast(np.ndarray, out)  # scipy is untyped

    def errors(
        self, *, T_C: np.ndarray, Q_W: np.ndarray, current_A: np.ndarray | None = None, start: int = 0
    ) -> dict[str, float]:
        """Free-run errors on a record from sample ``start`` on, W."""
        e = (self.free_run(T_C=T_C, current_A=current_A) - _as_1d("Q_W", Q_W))[start:]
        return {"free_run_max_W": float(np.max(np.abs(e))), "free_run_rms_W": float(np.sqrt(np.mean(e**2)))}


def fit_flux_arma(
    *,
    T_C: np.ndarray,
    Q_W: np.ndarray,
    n: int = 3,
    m: int = 3,
    period_s: float = 0.01,
    T_ref_C: float,
    current_A: np.ndarray | None = None,
    max_nfev: int = 400,
) -> FluxArma:
    """Fit the flux model by output error (see the module docstring).

    Args:
        T_C: temperatures, °C; Q_W: heat fluxes, W (same length, the record starting at rest).
        n, m: orders of eq. 12.
        period_s: s.
        T_ref_C: reference temperature, °C (the rest temperature, at which Q = 0).
        current_A: if given, the model gets the current terms (our extension) and is fitted with them.
        max_nfev: evaluation budget of the optimiser.

    Raises:
        ValueError: bad data, or no stable model found.
    """
    for name, v, lo in (("n", n, 1), ("m", m, 1)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not lo <= v <= MAX_ORDER:
            raise ValueError(f"flux model order {name} must be an integer in [{lo}, {MAX_ORDER}], got {v!r}")
    T = _as_1d("T_C", T_C) - T_ref_C
    Q = _as_1d("Q_W", Q_W)
    if len(T) != len(Q):
        raise ValueError(f"T_C and Q_W have different lengths ({len(T)} and {len(Q)})")
    I = None if current_A is None else _as_1d("current_A", current_A)
    if I is not None and len(I) != len(T):
        raise ValueError(f"T_C and current_A have different lengths ({len(T)} and {len(I)})")
    n_in = (m + 1) + (3 * m if I is not None else 0)
    if len(T) < 4 * (n + n_in):
        raise ValueError(f"need at least {4 * (n + n_in)} samples, got {len(T)}")
    x0 = _fir_start(T, Q, I, n, m)

    def unpack(x: np.ndarray) -> FluxArma:
        k = n + m + 1
        e, g, h = (
            (x[k : k + m], x[k + m : k + 2 * m], x[k + 2 * m :]) if I is not None else (np.zeros(0),) * 3
        )
        return FluxArma(
            c=x[:n], d=x[n : n + m + 1], e=e, g=g, h=h, period_s=float(period_s), T_ref_C=float(T_ref_C)
        )

    penalty = np.full(len(Q), 10.0 * (np.max(np.abs(Q)) + 1.0))

    def resid(x: np.ndarray) -> np.ndarray:
        if np.max(np.abs(np.roots(np.concatenate([[1.0], x[:n]])))) >= 0.9999:
            return penalty
        r = unpack(x).free_run(T_C=T + T_ref_C, current_A=I) - Q
        return r if np.all(np.isfinite(r)) else penalty

    sol = scipy.optimize.least_squares(resid, x0, method="lm", x_scale="jac", max_nfev=max_nfev)
    model = unpack(sol.x)
    pmax = float(np.max(np.abs(model.poles())))
    if pmax >= 0.9999:
        raise ValueError(f"flux model refused: pole |z| = {pmax:.6f} not inside the unit circle")
    r = sol.fun
    object.__setattr__(
        model,
        "metrics",
        {
            "n_samples": int(len(T)),
            "fit": "output-error",
            "with_current": I is not None,
            "train_free_run_rms_W": float(np.sqrt(np.mean(r**2))),
            "train_free_run_max_W": float(np.max(np.abs(r))),
            "max_pole_modulus": pmax,
            "nfev": int(sol.nfev),
        },
    )
    return model


def _fir_start(T: np.ndarray, Q: np.ndarray, I: np.ndarray | None, n: int, m: int) -> np.ndarray:
    """The optimiser's start: the FIR least-squares fit (c = 0), always stable; T in K from T_ref."""
    L = m
    cols = [T[L - j : len(T) - j] for j in range(m + 1)]
    if I is not None:
        cols += [I[L - j : len(T) - j] for j in range(1, m + 1)] + [
            I[L - j : len(T) - j] ** 2 for j in range(1, m + 1)
        ]
        cols += [I[L - j : len(T) - j] * T[L - j : len(T) - j] for j in range(1, m + 1)]
    A = np.column_stack(cols)
    scale = np.sqrt(np.mean(A * A, axis=0))
    scale[scale == 0] = 1.0
    b0 = np.linalg.lstsq(A / scale, Q[L:], rcond=None)[0] / scale
    return np.concatenate([np.zeros(n), b0])
