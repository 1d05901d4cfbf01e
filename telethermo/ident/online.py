"""Streaming NARMA identification for a node: the regressor φ(t) of eq. 11 built sample by sample and fed to
the guarded RLS of :mod:`telethermo.ident.rls` (guiatni §3.3's RLSM with λ1, λ2, K(0)).

    ident = OnlineNarma(NarmaOrders(3, 3, 3, 3), T_ref_C=25.0, period_s=0.01, lambda1=0.999, dead_zone=0.005)
    for each SYNC: ident.update(current_A=I_held_since_last_sample, T_C=sample.T_sensor_C)
    model = ident.model()        # a NarmaModel of the current estimate (stability not guaranteed: check it)
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from telethermo.ident.narma import NarmaModel, NarmaOrders, _as_1d, narma_regressors
from telethermo.ident.rls import Rls


class OnlineNarma:
    """RLS identification of a NARMA model from a stream of (current, temperature) samples.

    Args:
        orders: NARMA orders.
        T_ref_C: reference temperature, °C (the model works in deviations, see telethermo.ident.narma).
        period_s: sample period, s.
        scale: per-regressor scale (e.g. RMS of the columns on a typical record); default: a unit-free
            guess from ``current_scale_A`` and ``temperature_scale_C``.
        current_scale_A, temperature_scale_C: typical |I| and |T - T_ref| for the default scale.
        **rls: arguments of :class:`telethermo.ident.rls.Rls` (lambda1, lambda2, K0, dead_zone, ...).
    """

    def __init__(
        self,
        orders: NarmaOrders,
        *,
        T_ref_C: float,
        period_s: float,
        scale: np.ndarray | None = None,
        current_scale_A: float = 0.5,
        temperature_scale_C: float = 3.0,
        **rls: Any,
    ) -> None:
        self.orders = orders
        self.T_ref_C = float(T_ref_C)
        self.period_s = float(period_s)
        if scale is None:
            a = [
                temperature_scale_C * current_scale_A**k
                for _i in range(orders.n)
                for k in range(orders.p + 1)
            ]
            b = [current_scale_A ** (h + 1) for _j in range(orders.m) for h in range(orders.q + 1)]
            scale = np.array(a + b)
        self.rls = Rls(orders.d, scale=scale, **rls)
        self._T: list[float] = []
        self._I: list[float] = []
        self.I_min_A, self.I_max_A = math.inf, -math.inf
        self.n_rejected = 0

    def update(self, *, current_A: float, T_C: float) -> bool:
        """One sample: ``current_A`` held over the period that ended at this sample, ``T_C`` the sample, °C.

        Returns True if the RLS updated. A non-finite sample is rejected, counted, and restarts the
        history (the next max(n, m) samples only refill it).
        """
        I, T = float(current_A), float(T_C)
        if not (math.isfinite(I) and math.isfinite(T)):
            self.n_rejected += 1
            self._T.clear()
            self._I.clear()
            return False
        o = self.orders
        self._I.insert(0, I)
        del self._I[o.lag :]
        self.I_min_A, self.I_max_A = min(self.I_min_A, I), max(self.I_max_A, I)
        ok = False
        if len(self._T) >= o.n and len(self._I) >= o.m:
            phi = np.empty(o.d)
            c = 0
            for i in range(o.n):
                x, v = self._I[i], self._T[i]
                for _k in range(o.p + 1):
                    phi[c] = v
                    v *= x
                    c += 1
            for j in range(o.m):
                x = self._I[j]
                v = x
                for _h in range(o.q + 1):
                    phi[c] = v
                    v *= x
                    c += 1
            ok = self.rls.update(phi, T - self.T_ref_C)
        self._T.insert(0, T - self.T_ref_C)
        del self._T[o.n :]
        return ok

    def model(self) -> NarmaModel:
        """The current estimate as a :class:`NarmaModel` (not checked for stability)."""
        lo, hi = (self.I_min_A, self.I_max_A) if self.I_min_A <= self.I_max_A else (0.0, 0.0)
        return NarmaModel(
            orders=self.orders,
            theta=self.rls.theta,
            period_s=self.period_s,
            T_ref_C=self.T_ref_C,
            current_range_A=(lo, hi),
            T_range_C=(self.T_ref_C, self.T_ref_C),
            metrics={"method": "rls", "lambda1": self.rls.lambda1, "lambda2": self.rls.lambda2},
        )


def fit_narma_rls(
    *,
    current_A: np.ndarray,
    T_C: np.ndarray,
    orders: NarmaOrders,
    T_ref_C: float,
    period_s: float = 0.01,
    **rls: Any,
) -> NarmaModel:
    """Batch helper: run :class:`OnlineNarma` over a record (scale = RMS of the record's regressors)."""
    I = _as_1d("current_A", current_A)
    T = _as_1d("T_C", T_C)
    Phi, _ = narma_regressors(I, T - T_ref_C, orders)
    sc = np.sqrt(np.mean(Phi * Phi, axis=0))
    sc[sc == 0] = 1.0
    ident = OnlineNarma(orders, T_ref_C=T_ref_C, period_s=period_s, scale=sc, **rls)
    # current_A[k] is held from sample k to k+1: at sample k+1 the held current is current_A[k]
    ident.update(current_A=0.0, T_C=T[0])
    for k in range(1, len(T)):
        ident.update(current_A=I[k - 1], T_C=T[k])
    m = ident.model()
    return NarmaModel(
        orders=orders,
        theta=m.theta,
        period_s=period_s,
        T_ref_C=T_ref_C,
        current_range_A=(float(I.min()), float(I.max())),
        T_range_C=(float(T.min()), float(T.max())),
        metrics=m.metrics,
    )
