"""Fitting a NARMA temperature model (guiatni eq. 17) to a record: batch least squares on scaled
regressors, an optional output-error refinement, and the stability check that refuses a model a node
must not run. The model itself (orders, regressors, free run, predictor) is :mod:`telethermo.ident.narma`.
"""

from __future__ import annotations

from typing import Any, cast

import numpy as np
import scipy.linalg.lapack
import scipy.optimize

from telethermo.ident import stability
from telethermo.ident.narma import (
    NarmaModel,
    NarmaOrders,
    UnstableModelError,
    _as_1d,
    data_sha256,
    narma_regressors,
    solve_scaled_lstsq,
)


def fit_narma(
    *,
    current_A: np.ndarray,
    T_C: np.ndarray,
    orders: NarmaOrders = NarmaOrders(),
    period_s: float = 0.01,
    T_ref_C: float | None = None,
    check_stability: bool = True,
    validation: tuple[np.ndarray, np.ndarray] | None = None,
    method: str = "ls",
    max_nfev: int = 100,
) -> NarmaModel:
    """Fit a NARMA model (eq. 10) by batch least squares (eq. 17) on RMS-scaled columns (pivoted QR, never
    the normal equations).

    Args:
        current_A: drive currents, A (``current_A[k]`` held from sample k to k+1).
        T_C: pad temperatures, °C (on a free pad: the sensor temperature).
        orders: model orders.
        period_s: sample period of the data, s.
        T_ref_C: reference (rest) temperature, °C. Default: the mean temperature over the leading
            samples with zero current (the record should start at rest); if the record starts with a
            non-zero current, its first temperature.
        check_stability: refuse (raise :class:`UnstableModelError`) a model that fails
            :func:`telethermo.ident.stability.check_stability`.
        validation: optional held-out ``(current_A, T_C)`` record; its errors go into ``metrics``
            with the prefix ``heldout_``.
        method: ``"ls"``: batch least squares (eq. 17, equation error: minimises the one-step error);
            ``"oe"``: then refine by output error (:func:`refine_output_error`: minimises the free-run
            error, what the estimator uses; removes the bias LS has with coloured sensor noise).
        max_nfev: iteration budget of the output-error refinement.

    Returns:
        the fitted :class:`NarmaModel` with metrics ``rms_one_step_C``, ``free_run_max_C``, ... .
    """
    I = _as_1d("current_A", current_A)
    T = _as_1d("T_C", T_C)
    if len(I) != len(T):
        raise ValueError(f"current_A and T_C have different lengths ({len(I)} and {len(T)})")
    if not isinstance(orders, NarmaOrders):
        raise TypeError(f"orders must be a NarmaOrders, got {type(orders).__name__}")
    need = orders.lag + 2 * orders.d
    if len(I) < need:
        raise ValueError(f"need at least {need} samples to fit {orders.d} parameters, got {len(I)}")
    if T_ref_C is None:
        T_ref_C = _rest_temperature_C(I, T)
    if method not in ("ls", "oe"):
        raise ValueError(f"method must be 'ls' or 'oe', got {method!r}")
    Phi, y = narma_regressors(I, T - T_ref_C, orders)
    theta, diag = solve_scaled_lstsq(Phi, y)
    model = NarmaModel(
        orders=orders,
        theta=theta,
        period_s=float(period_s),
        T_ref_C=float(T_ref_C),
        current_range_A=(float(I.min()), float(I.max())),
        T_range_C=(float(T.min()), float(T.max())),
        metrics={},
        data_sha256=data_sha256(I, T),
    )
    metrics: dict[str, Any] = {
        "n_samples": int(len(I)),
        "rank": diag["rank"],
        "cond_scaled": diag["cond_scaled"],
        "method": method,
    }
    if method == "oe":
        model, oe = refine_output_error(model, current_A=I, T_C=T, max_nfev=max_nfev)
        metrics.update(oe)
    resid = y - Phi @ model.theta
    metrics["rms_one_step_C"] = float(np.sqrt(np.mean(resid**2)))
    metrics.update(_checked_free_run_metrics(model, I, T, check_stability, validation))
    object.__setattr__(model, "metrics", metrics)
    return model


def _rest_temperature_C(I: np.ndarray, T: np.ndarray) -> float:
    """The mean temperature, °C, over the leading samples with zero current (the first one if the
    record starts with a non-zero current)."""
    nz = np.flatnonzero(I != 0.0)
    lead = int(nz[0]) if nz.size else len(I)
    return float(np.mean(T[: lead + 1])) if lead > 0 else float(T[0])


def _checked_free_run_metrics(
    model: NarmaModel,
    I: np.ndarray,
    T: np.ndarray,
    check_stability: bool,
    validation: tuple[np.ndarray, np.ndarray] | None,
) -> dict[str, Any]:
    """The stability check (raises :class:`UnstableModelError`) and the free-run errors, °C, on the
    training record and the held-out one."""
    metrics: dict[str, Any] = {}
    if check_stability:
        rep = stability.check_stability(model)
        metrics["max_pole_modulus"] = rep.max_pole_modulus
        if not rep.stable:
            raise UnstableModelError(f"identified model refused: {rep.reason}")
    tr = model.errors(current_A=I, T_C=T)
    metrics.update(
        {"train_free_run_max_C": tr["free_run_max_C"], "train_free_run_rms_C": tr["free_run_rms_C"]}
    )
    if validation is not None:
        ev = model.errors(current_A=validation[0], T_C=validation[1])
        metrics.update({f"heldout_{k}": v for k, v in ev.items()})
    return metrics


def free_run_sensitivity(
    model: NarmaModel, *, current_A: np.ndarray, T_C: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Free run from rest at the record's first temperature (see :meth:`NarmaModel.errors`) and its
    Jacobian ∂T̂/∂θ.

    The free run T̂(t) = Σ_i α_i(t)·T̂(t-i) + u(t) is linear in θ given its own past, so
    ∂T̂(t)/∂θ = φ̂(t) + Σ_i α_i(t)·∂T̂(t-i)/∂θ (φ̂: the regressors built from T̂). Returns (T̂ in °C,
    J of shape (N, d)); rows of non-finite runs are left as computed (callers check).
    """
    o = model.orders
    I = model.clamp_current(np.asarray(current_A, dtype=float))
    T = np.asarray(T_C, dtype=float)
    L, N, n = o.lag, len(I), o.n
    fr = model.free_run(current_A=I, T0_C=float(T[0]))
    if not np.all(np.isfinite(fr)):
        return fr, np.full((N, o.d), np.nan)
    Phi, _ = narma_regressors(I, fr - model.T_ref_C, o)
    # (1 - Σ_i α_i(t)·q^-i)·J = φ̂: a unit lower-triangular banded system, solved in LAPACK (dtbtrs,
    # forward substitution without pivoting: the recursion itself) for all d columns at once
    alpha = model.ar_coefficients(I).T  # alpha[i-1, s] = α_i evaluated at I[s], used at t = s + i
    ab = np.zeros((n + 1, N))
    ab[0] = 1.0
    for i in range(1, n + 1):
        ab[i, : N - i] = -alpha[i - 1, : N - i]
    B = np.zeros((N, o.d), order="F")
    B[L:] = Phi
    with np.errstate(over="ignore", invalid="ignore"):
        J, info = scipy.linalg.lapack.dtbtrs(ab, B, uplo="L", diag="U", overwrite_b=True)
    if info != 0:
        J = np.full((N, o.d), np.nan)
    return fr, J


def refine_output_error(
    model: NarmaModel, *, current_A: np.ndarray, T_C: np.ndarray, max_nfev: int = 100
) -> tuple[NarmaModel, dict[str, Any]]:
    """Refine θ to minimise the free-run (simulation) error on a record (Levenberg-Marquardt with the
    exact Jacobian of :func:`free_run_sensitivity`, on RMS-scaled parameters), starting from ``model``.

    A trial θ whose free run diverges gets a large residual (the step is refused). Returns the refined
    model (or the start model if the refinement did not lower the free-run error) and its diagnostics
    ``oe_rms_before_C``, ``oe_rms_after_C``, ``oe_nfev``.
    """
    o = model.orders
    I = model.clamp_current(_as_1d("current_A", current_A))
    T = _as_1d("T_C", T_C)
    L = o.lag
    Phi, _ = narma_regressors(I, T - model.T_ref_C, o)
    sc = np.sqrt(np.mean(Phi * Phi, axis=0))
    sc[sc == 0] = 1.0
    penalty = np.full(len(T) - L, 1e3)
    cache: dict[str, np.ndarray] = {}

    def make(x: np.ndarray) -> NarmaModel:
        return NarmaModel(
            orders=o,
            theta=x / sc,
            period_s=model.period_s,
            T_ref_C=model.T_ref_C,
            current_range_A=model.current_range_A,
            T_range_C=model.T_range_C,
            data_sha256=model.data_sha256,
        )

    def resid(x: np.ndarray) -> np.ndarray:
        fr, J = free_run_sensitivity(make(x), current_A=I, T_C=T)
        if not (np.all(np.isfinite(fr)) and np.all(np.isfinite(J))):
            cache["J"] = np.zeros((len(T) - L, o.d))
            return penalty
        cache["J"] = J[L:] / sc
        return cast(np.ndarray, (fr - T)[L:])

    x0 = model.theta * sc
    r0 = resid(x0)
    rms0 = float(np.sqrt(np.mean(r0**2)))
    sol = scipy.optimize.least_squares(resid, x0, jac=lambda x: cache["J"], method="lm", max_nfev=max_nfev)
    rms1 = float(np.sqrt(np.mean(sol.fun**2)))
    best = make(sol.x) if rms1 < rms0 else model
    return best, {"oe_rms_before_C": rms0, "oe_rms_after_C": min(rms0, rms1), "oe_nfev": int(sol.nfev)}
