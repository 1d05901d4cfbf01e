"""RLS with two forgetting factors (guiatni §3.3): equivalence with batch LS, guiatni's recursion,
tracking, bounded covariance without excitation, rejection of non-finite samples, dead zone."""

import math

import numpy as np
import pytest

from telethermo.ident.narma import NarmaOrders, narma_regressors, solve_scaled_lstsq
from telethermo.ident.prbs import prbs
from telethermo.ident.rls import Rls


def narma_data(true_model, n_samples, seed, orders=NarmaOrders(3, 3, 3, 3), noise=0.002):
    rng = np.random.default_rng(seed)
    I = prbs(n_samples, amplitude_A=(0.1, 1.5), hold_samples=20, seed=seed)
    T = true_model.free_run(current_A=I, T0_C=25.0) + noise * rng.normal(size=n_samples)
    return narma_regressors(I, T - 25.0, orders)


def test_rls_equals_batch_ls_with_unit_forgetting_and_large_gain(true_model):
    """λ1 = λ2 = 1, K(0) = 1e10·I on the scaled order-3 NARMA regressors (d = 24, 8000 samples):
    θ_RLS = θ_LS to 1e-6 relative (the K(0)⁻¹ regularisation is ~1e-10 of ΦᵀΦ's smallest eigenvalue)."""
    Phi, y = narma_data(true_model, 8000, seed=1)
    theta_ls, diag = solve_scaled_lstsq(Phi, y)
    assert diag["rank"] == 24
    rls = Rls(24, lambda1=1.0, lambda2=1.0, K0=1e10, scale=np.sqrt(np.mean(Phi**2, axis=0)))
    for k in range(len(y)):
        assert rls.update(Phi[k], y[k])
    rel = np.linalg.norm(rls.theta - theta_ls) / np.linalg.norm(theta_ls)
    assert rel < 1e-6
    h = rls.health()
    assert h.n_accepted == len(y) and h.n_trace_capped == 0 and h.n_numerical_failures == 0


def test_square_root_form_follows_guiatnis_recursion():
    """K and θ equal guiatni's explicit recursion (λ1 = 0.97, λ2 = 0.8) step by step."""
    rng = np.random.default_rng(3)
    d, lam1, lam2 = 5, 0.97, 0.8
    K = np.diag([10.0, 1.0, 0.1, 5.0, 2.0])
    theta = np.zeros(d)
    rls = Rls(d, lambda1=lam1, lambda2=lam2, K0=K, trace_max=math.inf)
    for _ in range(300):
        phi, y = rng.normal(size=d), rng.normal()
        e0 = y - theta @ phi
        den = lam1 / lam2 + phi @ K @ phi
        theta = theta + K @ phi * e0 / den
        K = (K - np.outer(K @ phi, K @ phi) / den) / lam1
        rls.update(phi, y)
        assert np.allclose(rls.K, K, rtol=1e-9, atol=1e-12 * np.abs(K).max())
        assert np.allclose(rls.theta, theta, rtol=1e-9, atol=1e-12)
    assert rls.health().trace == pytest.approx(np.trace(K), rel=1e-9)


def test_rls_tracks_a_parameter_step_only_with_forgetting():
    rng = np.random.default_rng(5)
    d, N, step = 4, 6000, 3000
    th_a, th_b = np.array([1.0, -0.5, 0.2, 2.0]), np.array([1.3, -0.2, 0.2, 1.5])
    X = rng.normal(size=(N, d))
    y = np.where(np.arange(N) < step, X @ th_a, X @ th_b) + 0.01 * rng.normal(size=N)
    forget = Rls(d, lambda1=0.99, K0=100.0)
    plain = Rls(d, lambda1=1.0, K0=100.0)
    for k in range(N):
        forget.update(X[k], y[k])
        plain.update(X[k], y[k])
        if k == step - 1:
            assert np.max(np.abs(forget.theta - th_a)) < 0.01
    assert np.max(np.abs(forget.theta - th_b)) < 0.01  # memory ~100 samples: tracked
    assert np.max(np.abs(plain.theta - th_b)) > 0.1  # no forgetting: stuck at the average
    assert forget.health().n_trace_capped > 0 or forget.health().trace <= 4 * 100.0


def _converged_and_idle(true_model, seed):
    orders = NarmaOrders(2, 2, 1, 1)
    Phi, y = narma_data(true_model, 6000, seed=seed, orders=orders, noise=0.001)
    scale = np.sqrt(np.mean(Phi**2, axis=0))
    rng = np.random.default_rng(seed + 100)

    def idle(
        n,
    ):  # zero current, pad at rest: φ = sensor noise (σ = 1 mK) in the T columns, 0 in the I columns
        return narma_regressors(np.zeros(n + 2), 0.001 * rng.normal(size=n + 2), orders)

    return orders, Phi, y, scale, idle


ONE_HOUR = 360_000  # samples at 10 ms


@pytest.mark.slow  # 360,000 updates: ~5 s on an idle machine
def test_one_hour_without_excitation_keeps_covariance_bounded(true_model):
    """λ1 = 0.999, no dead zone: during 1 h of idle samples plain forgetting inflates K like λ1^-t in the
    unexcited (current) directions; the constant-trace bound holds tr K at its cap, K stays SPD and
    finite. Without the bound, 20,000 idle samples (200 s) already push tr K past 1000x the cap."""
    orders, Phi, y, scale, idle = _converged_and_idle(true_model, seed=2)
    bounded = Rls(orders.d, lambda1=0.999, K0=1e3, scale=scale)
    unbounded = Rls(orders.d, lambda1=0.999, K0=1e3, scale=scale, trace_max=math.inf)
    for k in range(4000):
        bounded.update(Phi[k], y[k])
        unbounded.update(Phi[k], y[k])
    trace_converged = bounded.health().trace
    Pi, yi = idle(ONE_HOUR)
    for k in range(len(yi)):
        bounded.update(Pi[k], yi[k])
    h = bounded.health()
    assert trace_converged < 0.5 * bounded.trace_max
    assert h.trace == pytest.approx(bounded.trace_max, rel=1e-6) and h.n_trace_capped > 0
    assert math.isfinite(h.condition) and h.min_eig > 0 and np.allclose(bounded.K, bounded.K.T)
    assert np.linalg.eigvalsh(bounded.K).min() > 0
    assert h.n_numerical_failures == 0 and h.n_accepted == 4000 + ONE_HOUR
    Pi, yi = idle(20_000)
    for k in range(len(yi)):
        unbounded.update(Pi[k], yi[k])
    assert unbounded.health().trace > 1e3 * bounded.trace_max


def test_one_hour_idle_with_dead_zone_then_excitation_no_jump(true_model):
    """With the dead zone at the noise level of the prediction error, 1 h of idle samples leaves θ and K
    alone, and the first 200 samples of renewed excitation move θ by less than 2 % (scaled units).
    Without the dead zone the noise-only data drag the AR coefficients towards 0 (white noise has no
    memory): the reason for the dead zone."""
    orders, Phi, y, scale, idle = _converged_and_idle(true_model, seed=4)
    guarded = Rls(orders.d, lambda1=0.999, K0=1e3, scale=scale, dead_zone=0.01)
    naive = Rls(orders.d, lambda1=0.999, K0=1e3, scale=scale)
    for k in range(4000):
        guarded.update(Phi[k], y[k])
        naive.update(Phi[k], y[k])
    theta_before = guarded.theta
    ref = np.max(np.abs(theta_before * scale))
    Pi, yi = idle(ONE_HOUR)
    for k in range(len(yi)):
        guarded.update(Pi[k], yi[k])
    for k in range(20_000):
        naive.update(Pi[k], yi[k])
    assert guarded.health().n_dead_zone > 0.999 * ONE_HOUR
    assert np.max(np.abs((guarded.theta - theta_before) * scale)) < 0.01 * ref
    drift = []
    for k in range(4000, 4200):
        guarded.update(Phi[k], y[k])
        drift.append(np.max(np.abs((guarded.theta - theta_before) * scale)))
    assert max(drift) < 0.02 * ref
    assert np.max(np.abs((naive.theta - theta_before) * scale)) > 0.3 * ref


@pytest.mark.filterwarnings(
    "ignore:overflow encountered:RuntimeWarning", "ignore:invalid value encountered:RuntimeWarning"
)
def test_nonfinite_samples_are_rejected_and_counted():
    rls = Rls(3, K0=10.0)
    for phi, y in [
        ([1.0, np.nan, 0.0], 1.0),
        ([1.0, 2.0, 3.0], np.inf),
        ([np.inf, 0.0, 0.0], 0.0),
        ([1e200, 1e200, 0.0], 1.0),
    ]:
        theta, K = rls.theta, rls.K
        assert rls.update(np.array(phi), y) is False
        assert np.array_equal(rls.theta, theta) and np.array_equal(rls.K, K)
    h = rls.health()
    assert h.n_rejected_nonfinite == 3 and h.n_updates == 4
    assert h.n_numerical_failures + h.n_rejected_nonfinite == 4  # the overflow is caught too
    assert rls.update(np.array([1.0, 0.0, 0.0]), 2.0) is True


def test_dead_zone_skips_small_errors_without_forgetting():
    rls = Rls(2, lambda1=0.9, K0=1.0, dead_zone=0.1, theta0=np.array([1.0, 1.0]))
    K = rls.K
    assert rls.update(np.array([1.0, 1.0]), 2.05) is False  # |e| = 0.05 <= 0.1
    assert np.array_equal(rls.K, K) and rls.health().n_dead_zone == 1
    assert rls.update(np.array([1.0, 1.0]), 2.5) is True


def test_covariance_reset_and_bad_arguments():
    rls = Rls(2, K0=5.0)
    for _ in range(50):
        rls.update(np.array([1.0, 0.5]), 1.0)
    rls.reset_covariance()
    assert np.allclose(rls.K, 5.0 * np.eye(2)) and rls.health().n_resets == 1
    for kwargs in [
        dict(lambda1=0.0),
        dict(lambda1=1.1),
        dict(lambda2=2.0),
        dict(K0=-1.0),
        dict(K0=np.ones((2, 2))),
        dict(dead_zone=-1.0),
    ]:
        with pytest.raises(ValueError):
            Rls(2, **kwargs)
    with pytest.raises(ValueError, match="shape"):
        rls.update(np.zeros(3), 0.0)
