"""NARMA temperature model of a TEM: the pad temperature from the drive current (guiatni eq. 7-11).

The model (eq. 10), written as a linear regression T(t) = θᵀφ(t) (eq. 11)::

    T(t) = Σ_{i=1..n} Σ_{k=0..p} θ_a[i,k] · I(t-i)^k · T(t-i)
         + Σ_{j=1..m} Σ_{h=0..q} θ_b[j,h] · I(t-j)^(h+1)

with guiatni's a_ik = -θ_a[i,k] and b_jh = θ_b[j,h]; d = n(p+1) + m(q+1) parameters.

**Temperatures are deviations** from a reference temperature ``T_ref_C`` carried by the model (and its
file): T(t) above is T_C(t) - T_ref_C. Eq. 10 has no constant term, so in absolute °C a model at rest
(I = 0) could only hold a non-zero temperature with an integrating pole (Σ a_i0 = -1). In deviation
form the rest state of the free pad (zero current, pad at ambient) is exactly T = 0, every local pole
can be strictly inside the unit circle, and the Peltier term α·T·I of eq. 5/6 splits into a deviation
part (the k = 1 terms) and α·T_ref·I, which the b_j0 terms absorb. T_ref_C is the ambient temperature
of the identification run (the rest temperature of the free pad); a node whose ambient differs may
pass its own rest temperature to :meth:`NarmaModel.predictor`.

Time indexing: sample t's temperature depends on the currents *held over the periods before it*
(I(t-1) is the current applied from sample t-1 to sample t). In arrays ``current_A[k]`` is the
current applied right after sample ``k`` was taken, ``T_C[k]`` is sample ``k``.

Fitting (:func:`telethermo.ident.narma_fit.fit_narma`) and the stability check
(:mod:`telethermo.ident.stability`) sit above this module.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np
import scipy.linalg

MAX_ORDER = 8
RCOND = 1e-12  # singular values of the scaled regressors below RCOND x the largest are treated as zero
#: NarmaPredictor.snapshot(): (T history relative to T_ref, I history, T_pred °C, clamped steps, steps)
NarmaSnapshot = tuple[tuple[float, ...], tuple[float, ...], float, int, int]


class UnstableModelError(ValueError):
    """An identified model is refused because it is unstable (the message says why)."""


@dataclass(frozen=True, slots=True)
class NarmaOrders:
    """Orders of the NARMA model (guiatni eq. 10).

    Attributes:
        n: autoregressive order in T (lags 1..n).
        m: order in I (lags 1..m).
        p: polynomial degree of a_i in I(t-i) (eq. 8).
        q: polynomial degree of b_j in I(t-j) (eq. 9).
    """

    n: int = 3
    m: int = 3
    p: int = 3
    q: int = 3

    def __post_init__(self) -> None:
        for name, lo in (("n", 1), ("m", 1), ("p", 0), ("q", 0)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not lo <= v <= MAX_ORDER:
                raise ValueError(f"NarmaOrders.{name} must be an integer in [{lo}, {MAX_ORDER}], got {v!r}")

    @property
    def d(self) -> int:
        """Number of parameters n(p+1) + m(q+1)."""
        return self.n * (self.p + 1) + self.m * (self.q + 1)

    @property
    def lag(self) -> int:
        """Longest lag max(n, m), samples: the history a prediction needs."""
        return max(self.n, self.m)

    @classmethod
    def parse(cls, text: str) -> "NarmaOrders":
        """Parse ``"n,m,p,q"`` (e.g. ``"3,3,3,3"``)."""
        parts = [s.strip() for s in str(text).split(",")]
        if len(parts) != 4 or not all(s.lstrip("-").isdigit() for s in parts):
            raise ValueError(f"orders must be four integers 'n,m,p,q', got {text!r}")
        return cls(*(int(s) for s in parts))

    def as_dict(self) -> dict[str, int]:
        return {"n": int(self.n), "m": int(self.m), "p": int(self.p), "q": int(self.q)}

    def column_names(self) -> list[str]:
        """Names of the regressors, in θ order (``T1*I1^2`` = T(t-1)·I(t-1)²)."""
        names = [f"T{i}*I{i}^{k}" if k else f"T{i}" for i in range(1, self.n + 1) for k in range(self.p + 1)]
        names += [f"I{j}^{h + 1}" for j in range(1, self.m + 1) for h in range(self.q + 1)]
        return names


def _as_1d(name: str, x: Any) -> np.ndarray:
    arr = np.asarray(x, dtype=float)
    if arr.ndim != 1:
        raise ValueError(f"{name} must be a 1-D array, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        bad = int(np.flatnonzero(~np.isfinite(arr))[0])
        raise ValueError(f"{name} must be finite; sample {bad} is {arr[bad]}")
    return arr


def narma_regressors(
    current_A: np.ndarray, T_dev: np.ndarray, orders: NarmaOrders
) -> tuple[np.ndarray, np.ndarray]:
    """Regression matrix Φ and targets y of eq. 11 for samples t = L..N-1 (L = orders.lag).

    Args:
        current_A: drive currents, A (``current_A[k]`` held from sample k to k+1).
        T_dev: temperatures as deviations from the model's reference, °C.
        orders: model orders.

    Returns:
        ``(Phi, y)``: Φ of shape (N-L, d) in θ order, y = T_dev[L:].
    """
    I = np.asarray(current_A, dtype=float)
    T = np.asarray(T_dev, dtype=float)
    N, L = len(I), orders.lag
    if len(T) != N:
        raise ValueError(f"current_A and T have different lengths ({N} and {len(T)})")
    if N <= L:
        raise ValueError(f"need more than {L} samples for orders {orders.as_dict()}, got {N}")
    rows = N - L
    Phi = np.empty((rows, orders.d))
    c = 0
    for i in range(1, orders.n + 1):
        Ii, col = I[L - i : N - i], T[L - i : N - i].copy()
        for _k in range(orders.p + 1):
            Phi[:, c] = col
            c += 1
            col = col * Ii
    for j in range(1, orders.m + 1):
        Ij = I[L - j : N - j]
        col = Ij.copy()
        for _h in range(orders.q + 1):
            Phi[:, c] = col
            c += 1
            col = col * Ij
    return Phi, T[L:].copy()


def data_sha256(current_A: np.ndarray, T_C: np.ndarray) -> str:
    """SHA-256 of the training data (float64, little-endian, current then temperature)."""
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(current_A, dtype="<f8").tobytes())
    h.update(np.ascontiguousarray(T_C, dtype="<f8").tobytes())
    return h.hexdigest()


def solve_scaled_lstsq(Phi: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, dict[str, float]]:
    """Least squares θ = argmin ||Φθ - y|| by QR with column pivoting on RMS-scaled columns.

    Never forms the normal equations. Columns are divided by their RMS (all-zero columns are left out
    and get θ = 0); trailing pivoted directions with |R_kk| below ``RCOND`` times |R_00| are dropped
    (their θ = 0: the basic solution) instead of amplifying noise. Returns θ and diagnostics: ``rank``,
    ``cond_scaled`` (2-norm condition number of the scaled Φ restricted to the kept columns, from the
    singular values of R).
    """
    scale = np.sqrt(np.einsum("ij,ij->j", Phi, Phi) / max(Phi.shape[0], 1))
    used = np.flatnonzero(scale > 0)
    theta = np.zeros(Phi.shape[1])
    if used.size == 0:
        return theta, {"rank": 0, "cond_scaled": math.inf, "n_params_used": 0}
    A = np.asfortranarray(Phi[:, used] / scale[used])
    Q, R, perm = scipy.linalg.qr(A, mode="economic", pivoting=True, check_finite=False, overwrite_a=True)
    diag = np.abs(np.diag(R))
    rank = int(np.count_nonzero(diag > RCOND * diag[0])) if diag[0] > 0 else 0
    if rank == 0:
        return theta, {"rank": 0, "cond_scaled": math.inf, "n_params_used": int(used.size)}
    Rr = R[:rank, :rank]
    sol = scipy.linalg.solve_triangular(Rr, Q[:, :rank].T @ y, check_finite=False)
    x = np.zeros(used.size)
    x[perm[:rank]] = sol
    theta[used] = x / scale[used]
    sv = np.linalg.svd(Rr, compute_uv=False)
    return theta, {
        "rank": rank,
        "cond_scaled": float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf,
        "n_params_used": int(used.size),
    }


@dataclass(frozen=True)
class NarmaModel:
    """An identified NARMA temperature model (eq. 10) in deviation form (see the module docstring).

    Attributes:
        orders: n, m, p, q.
        theta: parameters in regressor order (:meth:`NarmaOrders.column_names`); T_dev(t) = θᵀφ(t).
        period_s: sample period the model was identified at, s.
        T_ref_C: reference temperature, °C: temperatures in the regression are T_C - T_ref_C.
        current_range_A: (min, max) drive current of the training data, A; predictions clamp the
            current into this range (the polynomial in I is not trusted outside it).
        T_range_C: (min, max) temperature of the training data, °C.
        metrics: fit metrics (one-step and free-run errors on training and held-out data, °C; rank and
            condition number of the scaled regressors; number of samples).
        data_sha256: hash of the training data (:func:`data_sha256`).
    """

    orders: NarmaOrders
    theta: np.ndarray
    period_s: float
    T_ref_C: float
    current_range_A: tuple[float, float]
    T_range_C: tuple[float, float]
    metrics: dict[str, Any] = field(default_factory=dict)
    data_sha256: str = ""

    def __post_init__(self) -> None:
        theta = np.array(self.theta, dtype=float).reshape(-1)
        if theta.size != self.orders.d:
            raise ValueError(
                f"theta has {theta.size} values, orders {self.orders.as_dict()} need {self.orders.d}"
            )
        if not np.all(np.isfinite(theta)):
            raise ValueError("theta must be finite")
        if not (math.isfinite(self.period_s) and self.period_s > 0):
            raise ValueError(f"period_s must be a positive number of seconds, got {self.period_s!r}")
        if not math.isfinite(self.T_ref_C):
            raise ValueError(f"T_ref_C must be finite, got {self.T_ref_C!r}")
        lo, hi = (float(v) for v in self.current_range_A)
        if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
            raise ValueError(
                f"current_range_A must be (min, max) with min <= max, got {self.current_range_A!r}"
            )
        theta.setflags(write=False)
        object.__setattr__(self, "theta", theta)
        object.__setattr__(self, "current_range_A", (lo, hi))
        object.__setattr__(self, "T_range_C", tuple(float(v) for v in self.T_range_C))
        object.__setattr__(self, "metrics", dict(self.metrics))

    # -- coefficients -------------------------------------------------------------------------------
    @property
    def theta_a(self) -> np.ndarray:
        """θ_a as an (n, p+1) array: coefficient of I(t-i)^k·T(t-i) at [i-1, k] (guiatni's a = -θ_a)."""
        o = self.orders
        return self.theta[: o.n * (o.p + 1)].reshape(o.n, o.p + 1)

    @property
    def theta_b(self) -> np.ndarray:
        """θ_b as an (m, q+1) array: coefficient of I(t-j)^(h+1) at [j-1, h] (guiatni's b)."""
        o = self.orders
        return self.theta[o.n * (o.p + 1) :].reshape(o.m, o.q + 1)

    def ar_coefficients(self, current_A: float | np.ndarray) -> np.ndarray:
        """AR coefficients α_i(I) = Σ_k θ_a[i,k]·I^k for a constant current, shape (..., n)."""
        I = np.asarray(current_A, dtype=float)[..., None]
        return cast(np.ndarray, np.polynomial.polynomial.polyval(I, self.theta_a.T, tensor=False))

    def local_poles(self, current_A: float | np.ndarray) -> np.ndarray:
        """Poles (z) of the model linearised at a constant current, shape (..., n).

        For constant I the model is linear in T: T(t) = Σ α_i(I)·T(t-i) + const, so the poles are
        the roots of z^n - α_1 z^(n-1) - ... - α_n (exactly, not an approximation).
        """
        alpha = np.atleast_1d(self.ar_coefficients(current_A))
        n = self.orders.n
        comp = np.zeros(alpha.shape[:-1] + (n, n))
        comp[..., 0, :] = alpha
        if n > 1:
            idx = np.arange(n - 1)
            comp[..., idx + 1, idx] = 1.0
        return np.linalg.eigvals(comp)

    def steady_state_C(self, current_A: float | np.ndarray) -> np.ndarray:
        """Steady-state temperature at a constant current, °C (absolute)."""
        I = np.asarray(current_A, dtype=float)
        alpha = self.ar_coefficients(I)
        beta = np.polynomial.polynomial.polyval(
            I[..., None], np.vstack([np.zeros(self.orders.m), self.theta_b.T]), tensor=False
        )
        return cast(np.ndarray, self.T_ref_C + beta.sum(axis=-1) / (1.0 - alpha.sum(axis=-1)))

    def clamp_current(self, current_A: np.ndarray | float) -> np.ndarray:
        """The current clamped into the training range, A."""
        return np.clip(current_A, *self.current_range_A)

    # -- prediction ---------------------------------------------------------------------------------
    def predict_one_step(self, *, current_A: np.ndarray, T_C: np.ndarray) -> np.ndarray:
        """One-step-ahead prediction from measured temperatures, °C.

        ``out[t]`` predicts ``T_C[t]`` from ``T_C[t-1..t-n]`` and ``current_A[t-1..t-m]``; the first
        ``orders.lag`` values are NaN (no history).
        """
        I = self.clamp_current(_as_1d("current_A", current_A))
        T = _as_1d("T_C", T_C)
        if len(I) != len(T):
            raise ValueError(f"current_A and T_C have different lengths ({len(I)} and {len(T)})")
        out = np.full(len(T), np.nan)
        if len(T) > self.orders.lag:
            Phi, _ = narma_regressors(I, T - self.T_ref_C, self.orders)
            out[self.orders.lag :] = Phi @ self.theta + self.T_ref_C
        return out

    def free_run(self, *, current_A: np.ndarray, T0_C: float | np.ndarray) -> np.ndarray:
        """Free-run simulation (the default prediction): the model fed its own outputs, °C.

        Args:
            current_A: currents, A; ``current_A[k]`` is held from sample k to k+1.
            T0_C: the temperature at sample 0, °C (a float), or the first samples' temperatures (an
                array of length <= len(current_A)) which are copied to the output as initial conditions.
                Before sample 0 the pad is taken at rest at the first initial temperature with zero
                current.

        Returns:
            predicted temperatures, °C, same length as ``current_A``; ``out[k]`` depends only on
            ``current_A[:k]``. If the recursion diverges (|T - T_ref| > 1e6 °C), the rest is NaN.
        """
        I = self.clamp_current(_as_1d("current_A", current_A))
        T0 = np.atleast_1d(np.asarray(T0_C, dtype=float))
        if T0.ndim != 1 or T0.size < 1 or T0.size > max(len(I), 1) or not np.all(np.isfinite(T0)):
            raise ValueError("T0_C must be a finite float or a 1-D array no longer than current_A")
        N, n, m, L = len(I), self.orders.n, self.orders.m, self.orders.lag
        Ip = np.concatenate([np.zeros(L), I])
        # alpha[i][t] = α_{i+1}(Ip[t]);  forcing u[t] for output index t (padded coordinates)
        alpha = self.ar_coefficients(Ip).T  # (n, N+L)
        tb = np.vstack([np.zeros(m), self.theta_b.T])  # poly coefficients in I, degree 0..q+1, per lag j
        beta = np.polynomial.polynomial.polyval(Ip[:, None], tb, tensor=False).T  # (m, N+L)
        u = np.zeros(N + L)
        for j in range(1, m + 1):
            u[j:] += beta[j - 1, : N + L - j]
        Td = [float(T0[0] - self.T_ref_C)] * (N + L)
        for k, v in enumerate(T0):
            Td[L + k] = float(v - self.T_ref_C)
        a = [alpha[i].tolist() for i in range(n)]
        ul = u.tolist()
        start = L + T0.size
        diverged_at = None
        for t in range(start, N + L):
            acc = ul[t]
            for i in range(n):
                acc += a[i][t - i - 1] * Td[t - i - 1]
            if not -1e6 < acc < 1e6:
                diverged_at = t
                break
            Td[t] = acc
        out = np.asarray(Td[L:], dtype=float) + self.T_ref_C
        if diverged_at is not None:
            out[diverged_at - L :] = np.nan
        return out

    def predictor(self, T0_C: float, *, T_ref_C: float | None = None) -> "NarmaPredictor":
        """A streaming free-run predictor for a node, starting at rest at ``T0_C``
        (see :class:`NarmaPredictor`)."""
        return NarmaPredictor(self, T0_C, T_ref_C=T_ref_C)

    def errors(
        self, *, current_A: np.ndarray, T_C: np.ndarray, warmup: int | None = None, T0_C: float | None = None
    ) -> dict[str, float]:
        """Free-run and one-step errors of this model on a record, °C.

        The free run starts at rest at the record's first sample (the record should start at rest;
        ``T0_C`` overrides it, e.g. with the known rest temperature). Not from the first ``lag``
        samples copied as history: a TEM model at 10 ms has AR coefficients that nearly cancel
        (1 - Σα ~ 1e-8), and the noise in a copied history excites its slow modes with an enormous
        gain. Errors are taken from sample ``warmup`` (default: the lag) on. Keys: ``free_run_max_C``,
        ``free_run_rms_C``, ``one_step_max_C``, ``one_step_rms_C``.
        """
        T = _as_1d("T_C", T_C)
        L = self.orders.lag
        w = L if warmup is None else max(int(warmup), L)
        fr = self.free_run(current_A=current_A, T0_C=float(T[0]) if T0_C is None else float(T0_C))
        os_ = self.predict_one_step(current_A=current_A, T_C=T)
        efr, eos = (fr - T)[w:], (os_ - T)[w:]
        if efr.size == 0:
            raise ValueError(f"record too short to evaluate ({len(T)} samples, warm-up {w})")
        bad = not np.all(np.isfinite(efr))
        return {
            "free_run_max_C": math.inf if bad else float(np.max(np.abs(efr))),
            "free_run_rms_C": math.inf if bad else float(np.sqrt(np.mean(efr**2))),
            "one_step_max_C": float(np.max(np.abs(eos))),
            "one_step_rms_C": float(np.sqrt(np.mean(eos**2))),
        }


class NarmaPredictor:
    """Streaming free-run of a :class:`NarmaModel` for a node (one :meth:`step` per control period).

    The predictor starts at rest at ``T0_C`` (its whole history = T0_C with zero current).
    ``T_pred_C`` is the prediction for the sample about to be processed. ``step(current_A)`` takes the
    current **held over the period that starts at that sample**, advances one period and returns the
    prediction for the **next** sample (the first sample that this current affects; the prediction
    for a sample never depends on the current applied at that sample). So, on every SYNC k::

        T_pred = pred.T_pred_C                      # prediction for sample k
        T_f = 2 * sample.T_sensor_C - T_pred        # guiatni eq. 30
        I = controller(...)                         # current applied from sample k to k+1
        pred.step(I)                                # -> prediction for sample k+1

    (Equivalently a node may call ``T_pred = pred.step(I_prev)`` at the start of cycle k with the
    current held since sample k-1.) Currents outside the training range are clamped into it and
    counted in ``n_clamped``; a non-finite current raises ValueError and changes nothing.
    """

    __slots__ = (
        "model",
        "T_ref_C",
        "_a",
        "_b",
        "_T",
        "_I",
        "_n",
        "_m",
        "_p",
        "_q",
        "_lo",
        "_hi",
        "T_pred_C",
        "n_clamped",
        "n_steps",
    )

    def __init__(self, model: NarmaModel, T0_C: float, *, T_ref_C: float | None = None) -> None:
        self.model = model
        self.T_ref_C = float(model.T_ref_C if T_ref_C is None else T_ref_C)
        if not math.isfinite(self.T_ref_C):
            raise ValueError(f"T_ref_C must be finite, got {T_ref_C!r}")
        o = model.orders
        self._n, self._m, self._p, self._q = o.n, o.m, o.p, o.q
        self._a = [list(map(float, row))[::-1] for row in model.theta_a]  # highest degree first (Horner)
        self._b = [list(map(float, row))[::-1] for row in model.theta_b]
        self._lo, self._hi = model.current_range_A
        self.n_clamped = 0
        self.n_steps = 0
        self.reset(T0_C)

    def reset(self, T_C: float, current_A: float = 0.0) -> None:
        """Restart at rest: the whole history at ``T_C`` °C with ``current_A`` A held (default 0)."""
        T_C, current_A = float(T_C), float(current_A)
        if not (math.isfinite(T_C) and math.isfinite(current_A)):
            raise ValueError(f"reset needs finite values, got T_C={T_C!r}, current_A={current_A!r}")
        current_A = min(max(current_A, self._lo), self._hi)
        self._T = [T_C - self.T_ref_C] * self._n  # _T[0] = T(t-1) relative to the next prediction
        self._I = [current_A] * max(self._n, self._m)
        self.T_pred_C = T_C

    def snapshot(self) -> NarmaSnapshot:
        """The predictor's state as an immutable value (for a pure control step); see :meth:`restore`."""
        return (tuple(self._T), tuple(self._I), self.T_pred_C, self.n_clamped, self.n_steps)

    def restore(self, snap: NarmaSnapshot) -> None:
        """Return to a state taken by :meth:`snapshot` (of a predictor of the same model)."""
        T, I, T_pred, n_clamped, n_steps = snap
        if len(T) != len(self._T) or len(I) != len(self._I):
            raise ValueError("restore: the snapshot is of a predictor with other orders")
        self._T, self._I = list(T), list(I)
        self.T_pred_C, self.n_clamped, self.n_steps = float(T_pred), int(n_clamped), int(n_steps)

    def step(self, current_A: float) -> float:
        """Commit the current held over the coming period (A); return the prediction for the next
        sample, °C."""
        I = float(current_A)
        if not math.isfinite(I):
            raise ValueError(f"current_A must be finite, got {current_A!r}")
        if I < self._lo or I > self._hi:
            I = min(max(I, self._lo), self._hi)
            self.n_clamped += 1
        hist_I = self._I
        hist_I.pop()
        hist_I.insert(0, I)
        hist_T = self._T
        acc = 0.0
        for i in range(self._n):
            x = hist_I[i]
            c = 0.0
            for coef in self._a[i]:
                c = c * x + coef
            acc += c * hist_T[i]
        for j in range(self._m):
            x = hist_I[j]
            c = 0.0
            for coef in self._b[j]:
                c = c * x + coef
            acc += c * x
        hist_T.pop()
        hist_T.insert(0, acc)
        self.n_steps += 1
        self.T_pred_C = acc + self.T_ref_C
        return self.T_pred_C
