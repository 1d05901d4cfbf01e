"""Recursive least squares with two forgetting factors (guiatni §3.3), numerically guarded.

Guiatni's recursion (Landau's general form) for the gain (covariance) matrix K::

    K(t) = 1/λ1 · [K(t-1) - K(t-1)φφᵀK(t-1) / (λ1/λ2 + φᵀK(t-1)φ)]

is the inverse of the information recursion R(t) = λ1·R(t-1) + λ2·φφᵀ, and the matching parameter
update, which minimises Σ λ1^(t-s)·λ2·e(s)², is::

    θ(t) = θ(t-1) + K(t-1)φ·e°(t) / (λ1/λ2 + φᵀK(t-1)φ),   e°(t) = y(t) - θ(t-1)ᵀφ(t)

(guiatni print 1 + φᵀKφ in the denominator: the same for λ1 = λ2.) λ1 = λ2 = 1 is ordinary RLS, which
with a large K(0) reproduces batch least squares; λ1 < 1 forgets old data exponentially (tracking).

Numerical safety (what a node running this every cycle needs):

- **Square-root (Potter) form**: we store S with K = S·Sᵀ and update S by a rank-one factor, so K is
  symmetric and positive semi-definite *by construction* (no symmetrisation needed, no loss of
  definiteness by cancellation), and S's condition number is the square root of K's. O(d²) per update.
- **Bounded covariance: constant trace** (Landau). After each update, if tr K exceeds ``trace_max``
  (default tr K(0)), K is scaled back to ``trace_max``: an effective time-varying λ1 that never lets the
  gain wind up. With no excitation (φ = 0, or φ stuck in one direction) plain forgetting makes K grow
  as λ1^-t (after an hour at λ1 = 0.999, by 1e156: then a parameter jump at the next
  excitation); with the cap it stays at tr K(0). We chose it over EFRA (needs K², O(d³) per update) and
  directional forgetting (which, in the square-root form, needs a rank-one *downdate*), because it is
  O(d²), exact when inactive (with λ1 = 1 the trace only decreases, so RLS = batch LS), and it is the
  variant of Landau's framework that guiatni's λ1/λ2 notation comes from.
- **Dead zone**: no update (and no forgetting) while |e°| <= ``dead_zone`` (set it to about the noise
  level): idle periods neither drift the parameters nor use up the information.
- **Non-finite samples** (NaN/inf in φ or y) are rejected and counted; a numerical failure during an
  update (non-finite gain or covariance) restores θ, resets the covariance to K(0) and is counted.
- :meth:`Rls.reset_covariance` for an explicit covariance reset; :meth:`Rls.health` reports trace,
  condition number and the counters.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg.blas import dger as _dger


@dataclass(frozen=True, slots=True)
class RlsHealth:
    """Health metrics of an :class:`Rls` estimator.

    Attributes:
        trace: tr K (covariance / gain matrix).
        condition: 2-norm condition number of K.
        min_eig: smallest eigenvalue of K.
        n_updates: update() calls.
        n_accepted: updates that changed θ and K.
        n_rejected_nonfinite: samples rejected for NaN/inf in φ or y.
        n_dead_zone: samples skipped because |e°| <= dead_zone.
        n_trace_capped: updates after which tr K was scaled back to trace_max.
        n_resets: covariance resets (explicit or after a numerical failure).
        n_numerical_failures: updates undone because they produced non-finite numbers.
    """

    trace: float
    condition: float
    min_eig: float
    n_updates: int
    n_accepted: int
    n_rejected_nonfinite: int
    n_dead_zone: int
    n_trace_capped: int
    n_resets: int
    n_numerical_failures: int


class Rls:
    """Streaming RLS estimator of θ in y = θᵀφ (see the module docstring for the algorithm).

    Args:
        d: number of parameters.
        lambda1: forgetting factor λ1 in (0, 1] (1: no forgetting).
        lambda2: weight λ2 in (0, 2) of the new sample (guiatni's second factor; 1 in ordinary RLS).
        K0: initial gain K(0): a positive number (K(0) = K0·I) or a symmetric positive-definite (d, d)
            matrix. Large K0 = little confidence in ``theta0``.
        theta0: initial parameters (default zeros).
        trace_max: cap on tr K (constant-trace bound); default tr K(0); ``math.inf`` disables it.
        trace_min: floor on tr K (keeps the estimator alert with λ1 = 1); default 0 (off).
        dead_zone: no update while |y - θᵀφ| <= dead_zone (units of y).
        scale: optional per-regressor scale (e.g. the RMS of each column); the filter then works on
            φ/scale, which conditions K better; :attr:`theta` is always in the units of φ.
    """

    __slots__ = (
        "d",
        "lambda1",
        "lambda2",
        "_r",
        "_inv_sqrt_l1",
        "_S",
        "_S0",
        "_c",
        "_tr",
        "_theta",
        "_scale",
        "trace_max",
        "trace_min",
        "dead_zone",
        "n_updates",
        "n_accepted",
        "n_rejected_nonfinite",
        "n_dead_zone",
        "n_trace_capped",
        "n_resets",
        "n_numerical_failures",
    )

    def __init__(
        self,
        d: int,
        *,
        lambda1: float = 1.0,
        lambda2: float = 1.0,
        K0: float | np.ndarray = 1e4,
        theta0: np.ndarray | None = None,
        trace_max: float | None = None,
        trace_min: float = 0.0,
        dead_zone: float = 0.0,
        scale: np.ndarray | None = None,
    ) -> None:
        if isinstance(d, bool) or not isinstance(d, (int, np.integer)) or d < 1:
            raise ValueError(f"d must be a positive integer, got {d!r}")
        self.d = int(d)
        if not (0.0 < lambda1 <= 1.0):
            raise ValueError(f"lambda1 must be in (0, 1], got {lambda1!r}")
        if not (0.0 < lambda2 < 2.0):
            raise ValueError(f"lambda2 must be in (0, 2), got {lambda2!r}")
        if not (math.isfinite(dead_zone) and dead_zone >= 0.0):
            raise ValueError(f"dead_zone must be >= 0, got {dead_zone!r}")
        self.lambda1, self.lambda2 = float(lambda1), float(lambda2)
        self._r = self.lambda1 / self.lambda2
        self._inv_sqrt_l1 = 1.0 / math.sqrt(self.lambda1)
        if np.ndim(K0) == 0:
            k0 = float(K0)
            if not (math.isfinite(k0) and k0 > 0):
                raise ValueError(f"K0 must be a positive number or an SPD matrix, got {K0!r}")
            S0 = math.sqrt(k0) * np.eye(self.d)
        else:
            K = np.asarray(K0, dtype=float)
            if K.shape != (self.d, self.d) or not np.all(np.isfinite(K)) or not np.allclose(K, K.T):
                raise ValueError(f"K0 must be a symmetric ({self.d}, {self.d}) matrix")
            try:
                S0 = np.linalg.cholesky(K)
            except np.linalg.LinAlgError:
                raise ValueError("K0 must be positive definite") from None
        self._S0 = S0
        self._S = S0.copy()  # K = _c · _S·_Sᵀ (the scalar _c carries forgetting and trace scaling)
        self._c = 1.0
        self._tr = float(np.sum(S0 * S0))  # tr K, tracked analytically, recomputed every RENORM updates
        if scale is None:
            self._scale = None
        else:
            sc = np.asarray(scale, dtype=float).reshape(-1)
            if sc.shape != (self.d,) or not np.all(np.isfinite(sc)) or np.any(sc <= 0):
                raise ValueError(f"scale must be {self.d} positive finite numbers")
            self._scale = sc
        th = np.zeros(self.d) if theta0 is None else np.asarray(theta0, dtype=float).reshape(-1).copy()
        if th.shape != (self.d,) or not np.all(np.isfinite(th)):
            raise ValueError(f"theta0 must be {self.d} finite numbers")
        self._theta = th if self._scale is None else th * self._scale
        tr0 = float(np.sum(S0 * S0))
        self.trace_max = tr0 if trace_max is None else float(trace_max)
        self.trace_min = float(trace_min)
        if not (self.trace_max > 0) or not (0 <= self.trace_min < self.trace_max):
            raise ValueError(f"need 0 <= trace_min < trace_max, got {self.trace_min!r}, {self.trace_max!r}")
        self.dead_zone = float(dead_zone)
        self.n_updates = self.n_accepted = self.n_rejected_nonfinite = self.n_dead_zone = 0
        self.n_trace_capped = self.n_resets = self.n_numerical_failures = 0

    # -- state --------------------------------------------------------------------------------------
    @property
    def theta(self) -> np.ndarray:
        """Current parameter estimate (a copy), in the units of φ."""
        return self._theta.copy() if self._scale is None else self._theta / self._scale

    @property
    def K(self) -> np.ndarray:
        """Current gain (covariance) matrix K = S·Sᵀ, in the scaled coordinates if ``scale`` was given."""
        return self._c * (self._S @ self._S.T)

    def predict(self, phi: np.ndarray) -> float:
        """θᵀφ."""
        return float(self.theta @ np.asarray(phi, dtype=float))

    def reset_covariance(self, K0: float | np.ndarray | None = None) -> None:
        """Reset K to K(0) (or to a new K0: a positive number or an SPD matrix); θ is kept."""
        if K0 is None:
            S = self._S0.copy()
        elif np.ndim(K0) == 0:
            if not (math.isfinite(float(K0)) and float(K0) > 0):
                raise ValueError(f"K0 must be positive, got {K0!r}")
            S = math.sqrt(float(K0)) * np.eye(self.d)
        else:
            S = np.linalg.cholesky(np.asarray(K0, dtype=float))
        self._S, self._c, self._tr = S, 1.0, float(np.sum(S * S))
        self.n_resets += 1

    # -- the update ---------------------------------------------------------------------------------
    RENORM = 500  # updates between folding _c into _S and recomputing tr K exactly

    def update(self, phi: np.ndarray, y: float) -> bool:
        """Take one sample (φ, y). Returns True if θ and K were updated, False if the sample was rejected
        (non-finite), skipped by the dead zone, or undone after a numerical failure. O(d²)."""
        self.n_updates += 1
        z = phi if type(phi) is np.ndarray and phi.dtype == np.float64 else np.asarray(phi, dtype=float)
        if z.shape != (self.d,):
            raise ValueError(f"phi must have shape ({self.d},), got {z.shape}")
        if self._scale is not None:
            z = z / self._scale
        theta = self._theta
        e = float(y) - float(theta @ z)  # NaN/inf anywhere in φ or y makes e non-finite
        if not math.isfinite(e):
            self.n_rejected_nonfinite += 1
            return False
        if abs(e) <= self.dead_zone:
            self.n_dead_zone += 1
            return False
        # Potter square-root step on K = c·S·Sᵀ: f = √c·Sᵀφ, u = S·f ...
        S, c, r = self._S, self._c, self._r
        f = S.T @ z
        ff = c * float(f @ f)  # φᵀKφ
        s = r + ff
        u = S @ f
        uu = c * c * float(u @ u)  # φᵀK²φ = ||Kφ||²
        b0 = 1.0 / (s + math.sqrt(r * s))  # Potter's factor for the true square root √c·S
        beta = c * b0
        # tr of (√c·S - b0·Kφ·(√c·f)ᵀ)(...)ᵀ, then forgetting
        tr = (self._tr - uu * b0 * (2.0 - b0 * ff)) / self.lambda1
        if not (math.isfinite(s) and math.isfinite(tr) and tr > 0.0):
            self._numerical_failure()
            return False
        self._theta = theta + u * (c * e / s)  # θ += K(t-1)φ·e°/(λ1/λ2 + φᵀK(t-1)φ)
        # S -= β·u·fᵀ in place by BLAS dger on Sᵀ (a Fortran-ordered view of the C-ordered S: in place)
        if not S.flags.c_contiguous:
            self._S = S = np.ascontiguousarray(S)
        _dger(-beta, f, u, a=S.T, overwrite_a=1)
        c /= self.lambda1
        if tr > self.trace_max:
            c *= self.trace_max / tr
            tr = self.trace_max
            self.n_trace_capped += 1
        elif tr < self.trace_min:
            c *= self.trace_min / tr
            tr = self.trace_min
        self._c, self._tr = c, tr
        self.n_accepted += 1
        if self.n_accepted % self.RENORM == 0:
            self._renormalise()
        return True

    def _renormalise(self) -> None:
        """Fold c into S and recompute tr K exactly (bounds the drift of the analytic trace)."""
        S = self._S * math.sqrt(self._c)
        tr = float(np.einsum("ij,ij->", S, S))
        if not (math.isfinite(tr) and tr > 0.0):
            self._numerical_failure()
            return
        self._S, self._c, self._tr = S, 1.0, tr

    def _numerical_failure(self) -> None:
        self.n_numerical_failures += 1
        self.reset_covariance()

    def health(self) -> RlsHealth:
        """Trace, condition number, smallest eigenvalue of K and the counters (O(d³): not every cycle)."""
        sv = np.linalg.svd(self._S, compute_uv=False)
        eig = self._c * sv * sv
        return RlsHealth(
            trace=float(eig.sum()),
            condition=float(eig[0] / eig[-1]) if eig[-1] > 0 else math.inf,
            min_eig=float(eig[-1]),
            n_updates=self.n_updates,
            n_accepted=self.n_accepted,
            n_rejected_nonfinite=self.n_rejected_nonfinite,
            n_dead_zone=self.n_dead_zone,
            n_trace_capped=self.n_trace_capped,
            n_resets=self.n_resets,
            n_numerical_failures=self.n_numerical_failures,
        )
