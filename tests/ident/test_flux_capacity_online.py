"""Heat-flux ARMA (eq. 12), capacity model (eq. 13) and the streaming RLS identifier, on data from known
models."""

import numpy as np
import pytest
import scipy.signal

from telethermo.ident import NarmaOrders, fit_capacity, fit_flux_arma, fit_narma, prbs
from telethermo.ident.flux import FluxArma
from telethermo.ident.online import OnlineNarma, fit_narma_rls

from .conftest import TRUE_ORDERS


def test_flux_arma_recovers_a_known_model_by_output_error():
    """Q = -c1 Q(t-1) - c2 Q(t-2) + Σ d_j T(t-j) plus output noise σ = 1 mW: output error recovers the
    model; its free run is within 4σ of the noise-free flux on fresh data."""
    rng = np.random.default_rng(1)
    c, d = np.array([-1.2, 0.4]), np.array([0.8, -1.1, 0.35])
    T = 25.0 + scipy.signal.lfilter([0.2], [1, -0.9], rng.normal(size=8000))
    Q = scipy.signal.lfilter(d, np.r_[1, c], T - 25.0)
    f = fit_flux_arma(T_C=T, Q_W=Q + 0.001 * rng.normal(size=len(Q)), n=2, m=2, T_ref_C=25.0)
    assert f.c == pytest.approx(c, abs=0.005) and f.d == pytest.approx(d, abs=0.005)
    T2 = 25.0 + scipy.signal.lfilter([0.2], [1, -0.7], rng.normal(size=3000))
    Q2 = scipy.signal.lfilter(d, np.r_[1, c], T2 - 25.0)
    assert f.errors(T_C=T2, Q_W=Q2)["free_run_max_W"] < 0.004


def test_flux_model_with_current_terms():
    rng = np.random.default_rng(2)
    I = prbs(6000, amplitude_A=(0.1, 1.0), hold_samples=10, seed=2)
    # T: driven by I, plus a slow independent disturbance (else T and I are collinear in eq. 12)
    T = (
        25.0
        + scipy.signal.lfilter([0.0, 0.05], [1, -0.95], I)
        + scipy.signal.lfilter([0.02], [1, -0.99], rng.normal(size=6000))
    )
    true = FluxArma(c=[-0.5], d=[0.3, -0.3], e=[0.02], g=[0.01], h=[0.005], period_s=0.01, T_ref_C=25.0)
    Q = true.free_run(T_C=T, current_A=I)
    f = fit_flux_arma(T_C=T, Q_W=Q + 1e-4 * rng.normal(size=len(Q)), n=1, m=1, T_ref_C=25.0, current_A=I)
    assert (
        f.with_current and f.e == pytest.approx([0.02], abs=2e-3) and f.g == pytest.approx([0.01], abs=2e-3)
    )
    assert f.h == pytest.approx([0.005], abs=1e-3)
    with pytest.raises(ValueError, match="current_A"):
        f.free_run(T_C=T)


def test_flux_fit_rejects_bad_input():
    with pytest.raises(ValueError, match="order"):
        fit_flux_arma(T_C=np.ones(100), Q_W=np.ones(100), n=0, T_ref_C=25.0)
    with pytest.raises(ValueError, match="lengths"):
        fit_flux_arma(T_C=np.ones(100), Q_W=np.ones(99), T_ref_C=25.0)


def test_capacity_model_recovers_guiatni_eq5_exactly():
    """Eq. 13 has the form of eq. 5/6 with the sink side at a fixed temperature: data from eq. 6
    (α = 0.05 V/K, R = 2 Ω, K = 0.3 W/K, T_s = 25 °C) are fitted exactly; θ1 = α, θ2 = R/2."""
    alpha, R, K, Ts, kelvin = 0.05, 2.0, 0.3, 25.0, 273.15
    I = np.linspace(-1.5, 1.5, 14)
    T = 25.0 + 8.0 * I + 3.0 * I**2 + np.sin(7 * I)  # steady-state pad temperatures, °C
    P = alpha * (T + kelvin) * I + 0.5 * R * I**2 - K * (T - Ts)
    cap = fit_capacity(current_A=I, T_C=T, P_W=P)
    assert cap.theta == pytest.approx([alpha, R / 2, -K, alpha * kelvin, K * Ts], rel=1e-8)
    assert cap.metrics["max_abs_W"] < 1e-10
    assert cap.predict(current_A=0.7, T_C=30.0) == pytest.approx(alpha * 303.15 * 0.7 + 0.49 - 1.5, rel=1e-9)
    with pytest.raises(ValueError, match="at least 5"):
        fit_capacity(current_A=I[:4], T_C=T[:4], P_W=P[:4])


def test_online_rls_identifier_matches_batch_ls(true_model):
    """The streaming identifier (φ built sample by sample, λ1 = λ2 = 1, K0 = 1e10) = batch LS to 1e-6."""
    rng = np.random.default_rng(3)
    I = prbs(6000, amplitude_A=(0.1, 1.5), hold_samples=20, seed=3)
    T = true_model.free_run(current_A=I, T0_C=25.0) + 0.002 * rng.normal(size=6000)
    ls = fit_narma(current_A=I, T_C=T, orders=TRUE_ORDERS, T_ref_C=25.0)
    rls = fit_narma_rls(current_A=I, T_C=T, orders=TRUE_ORDERS, T_ref_C=25.0, K0=1e10)
    assert np.linalg.norm(rls.theta - ls.theta) / np.linalg.norm(ls.theta) < 1e-6


def test_online_identifier_rejects_nan_and_refills_history(true_model):
    ident = OnlineNarma(NarmaOrders(2, 2, 1, 1), T_ref_C=25.0, period_s=0.01, K0=100.0)
    assert ident.update(current_A=0.0, T_C=25.0) is False  # history not full yet
    assert ident.update(current_A=0.5, T_C=25.1) is False
    assert ident.update(current_A=0.5, T_C=25.2) is True
    assert ident.update(current_A=0.5, T_C=float("nan")) is False
    assert ident.n_rejected == 1
    assert [ident.update(current_A=0.5, T_C=25.3 + 0.1 * k) for k in range(3)] == [False, False, True]
