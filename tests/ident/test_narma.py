"""NARMA model (guiatni eq. 10/11): regressors, LS recovery of known coefficients, free run, predictor,
stability check."""

import math

import numpy as np
import pytest
from hypothesis import assume, example, given, settings, strategies as st

from telethermo.ident.narma import NarmaModel, NarmaOrders, UnstableModelError, narma_regressors
from telethermo.ident.narma_fit import fit_narma
from telethermo.ident.prbs import prbs
from telethermo.ident.stability import check_stability

from .conftest import TRUE_ORDERS, TRUE_THETA


def test_orders_validate_and_parse():
    assert NarmaOrders.parse("3, 3,2,1") == NarmaOrders(3, 3, 2, 1)
    assert NarmaOrders(3, 3, 3, 3).d == 24  # n(p+1) + m(q+1), guiatni §2.2
    for bad in [dict(n=0), dict(m=0), dict(p=-1), dict(q=9), dict(n=1.5), dict(n=True)]:
        with pytest.raises(ValueError):
            NarmaOrders(**bad)
    with pytest.raises(ValueError, match="n,m,p,q"):
        NarmaOrders.parse("3,3,3")


def test_regressor_columns_are_eq10_terms():
    o = NarmaOrders(n=2, m=3, p=2, q=1)
    rng = np.random.default_rng(1)
    I, T = rng.normal(size=12), rng.normal(size=12)
    Phi, y = narma_regressors(I, T, o)
    t = 7  # a row: sample t = L + row
    row = Phi[t - o.lag]
    expect = {f"T{i}*I{i}^{k}" if k else f"T{i}": T[t - i] * I[t - i] ** k for i in (1, 2) for k in (0, 1, 2)}
    expect.update({f"I{j}^{h + 1}": I[t - j] ** (h + 1) for j in (1, 2, 3) for h in (0, 1)})
    assert [expect[c] for c in o.column_names()] == pytest.approx(row.tolist(), rel=1e-14)
    assert y[t - o.lag] == T[t]


def test_recovers_known_coefficients_with_noise(true_model):
    """Equation-error noise σ = 0.01 °C: LS is unbiased and each coefficient lies within 5 of its
    theoretical standard deviations σ·sqrt(diag((ΦᵀΦ)⁻¹)); the tolerance means something: 10x the
    noise breaks it."""
    rng = np.random.default_rng(7)
    N, sigma = 20_000, 0.01
    I = prbs(N, amplitude_A=(0.1, 1.5), hold_samples=20, seed=11)
    T = np.full(N, 0.0)
    e = sigma * rng.normal(size=N)
    th = TRUE_THETA
    for t in range(2, N):  # T(t) = θᵀφ(t) + e(t), deviations from T_ref
        T[t] = (
            (th[0] + th[1] * I[t - 1]) * T[t - 1]
            + (th[2] + th[3] * I[t - 2]) * T[t - 2]
            + th[4] * I[t - 1]
            + th[5] * I[t - 1] ** 2
            + th[6] * I[t - 2]
            + th[7] * I[t - 2] ** 2
            + e[t]
        )
    model = fit_narma(current_A=I, T_C=T + 25.0, orders=TRUE_ORDERS, period_s=0.01, T_ref_C=25.0)
    Phi, _ = narma_regressors(I, T, TRUE_ORDERS)
    Q, R = np.linalg.qr(Phi)
    Rinv = np.linalg.inv(R)
    sd = sigma * np.sqrt(np.sum(Rinv**2, axis=1))
    z = (model.theta - th) / sd
    assert np.all(np.abs(z) < 5.0), z
    assert model.metrics["rms_one_step_C"] == pytest.approx(sigma, rel=0.05)


def test_overparametrised_fit_reproduces_noise_free_data(true_model):
    """Order 3 (d = 24) on data of the order-(2,2,1,1) model: free-run error at rounding level."""
    I = prbs(8000, amplitude_A=(0.1, 1.5), hold_samples=15, seed=5)
    T = true_model.free_run(current_A=I, T0_C=25.0)
    model = fit_narma(current_A=I, T_C=T, orders=NarmaOrders(3, 3, 3, 3))
    assert model.T_ref_C == 25.0  # taken from the rest samples at the start... here T[0]
    I2 = prbs(5000, amplitude_A=(0.1, 1.5), hold_samples=7, seed=6)
    T2 = true_model.free_run(current_A=I2, T0_C=25.0)
    assert model.errors(current_A=I2, T_C=T2)["free_run_max_C"] < 1e-8


def test_free_run_is_causal_and_matches_streaming_predictor(true_model):
    I = prbs(600, amplitude_A=(0.1, 1.5), hold_samples=5, seed=2)
    T = true_model.free_run(current_A=I, T0_C=27.0)
    assert T[0] == 27.0
    I2 = I.copy()
    I2[300] += 0.3
    T2 = true_model.free_run(current_A=I2, T0_C=27.0)
    assert np.array_equal(T[:301], T2[:301]) and T2[301] != T[301]  # out[k] depends on current_A[:k] only
    pred = true_model.predictor(27.0)
    assert pred.T_pred_C == 27.0
    stream = [pred.T_pred_C] + [pred.step(i) for i in I[:-1]]
    assert np.max(np.abs(np.array(stream) - T)) < 1e-12
    pred.reset(25.0)  # at rest at T_ref: stays there
    assert all(pred.step(0.0) == 25.0 for _ in range(50))


def test_predictor_clamps_current_and_rejects_nan(true_model):
    pred = true_model.predictor(25.0)
    a = pred.step(5.0)  # outside the training range (-1.5, 1.5): clamped
    pred2 = true_model.predictor(25.0)
    assert a == pred2.step(1.5) and pred.n_clamped == 1 and pred2.n_clamped == 0
    with pytest.raises(ValueError):
        pred.step(float("nan"))
    assert pred.n_steps == 1


def test_steady_state_matches_long_free_run(true_model):
    for I0 in (-1.2, 0.0, 0.7):
        T = true_model.free_run(current_A=np.full(3000, I0), T0_C=25.0)
        assert T[-1] == pytest.approx(float(true_model.steady_state_C(I0)), abs=1e-9)


def test_one_step_prediction_uses_measured_history(true_model):
    I = prbs(400, amplitude_A=(0.1, 1.5), hold_samples=5, seed=9)
    T = true_model.free_run(current_A=I, T0_C=25.0) + 0.05 * np.sin(np.arange(400))
    p = true_model.predict_one_step(current_A=I, T_C=T)
    assert np.all(np.isnan(p[:2]))
    t = 100
    a = true_model.ar_coefficients(I[t - 1])[0] * (T[t - 1] - 25) + true_model.ar_coefficients(I[t - 2])[
        1
    ] * (T[t - 2] - 25)
    b = 0.05 * I[t - 1] + 0.02 * I[t - 1] ** 2 - 0.03 * I[t - 2] + 0.01 * I[t - 2] ** 2
    assert p[t] == pytest.approx(25 + a + b, abs=1e-12)


def test_stability_check_refuses_unstable_models_with_reason(true_model):
    rep = check_stability(true_model)
    a1, a2 = 1.6 + 0.01 * 1.5, -0.62 - 0.005 * 1.5  # worst at I = 1.5 A: z² - a1 z - a2 = 0
    assert rep.stable and rep.max_pole_modulus == pytest.approx(
        (a1 + math.sqrt(a1**2 + 4 * a2)) / 2, rel=1e-9
    )
    # a pole crossing 1 at large current: θ_a[1,1] large -> α_1(I) = 1.6 + 0.2 I
    th = TRUE_THETA.copy()
    th[1] = 0.2
    bad = NarmaModel(
        orders=TRUE_ORDERS,
        theta=th,
        period_s=0.01,
        T_ref_C=25.0,
        current_range_A=(-1.5, 1.5),
        T_range_C=(15, 43),
    )
    rep = check_stability(bad)
    assert not rep.stable and "local pole" in rep.reason and rep.worst_current_A == pytest.approx(1.5)
    # an integrator (Σα = 1 at I = 0)
    th = TRUE_THETA.copy()
    th[2] = -0.6
    rep = check_stability(
        NarmaModel(
            orders=TRUE_ORDERS,
            theta=th,
            period_s=0.01,
            T_ref_C=25.0,
            current_range_A=(-1.5, 1.5),
            T_range_C=(15, 43),
        )
    )
    assert not rep.stable and rep.max_pole_modulus >= 1.0 - 1e-9


def test_time_varying_instability_is_caught_by_free_run():
    """Frozen-current poles all at |z| = 0.9 but switching the current between ±1 every sample
    alternates two matrices whose product is unstable: only the long free run sees it."""
    o = NarmaOrders(n=2, m=1, p=1, q=0)
    # α1(I) = 0.0 + 0*I ... use α1 = 1.8 I? poles of z² - α1 z - α2 with α1 = ±1.8·I... keep |z| < 1:
    # α1(I) = 1.2·I, α2 = -0.81: poles |z| = 0.9 for |I| <= 1 (complex pair)
    th = np.array([0.0, 1.2, -0.81, 0.0, 1.0])
    m = NarmaModel(
        orders=o, theta=th, period_s=0.01, T_ref_C=25.0, current_range_A=(-1.0, 1.0), T_range_C=(20, 30)
    )
    assert np.max(np.abs(m.local_poles(np.linspace(-1, 1, 201)))) == pytest.approx(0.9, abs=1e-9)
    rep = check_stability(m)
    assert not rep.stable and "free run" in rep.reason


def test_fit_refuses_unstable_result():
    """Data from an unstable plant (pole 1.002): the fit finds the pole and the model is refused."""
    rng = np.random.default_rng(0)
    I = prbs(2000, amplitude_A=(0.1, 1.0), hold_samples=10, seed=1)
    T = np.zeros(2000)
    for t in range(1, 2000):
        T[t] = 1.002 * T[t - 1] + 0.01 * I[t - 1] + 1e-4 * rng.normal()
    T += 25.0
    with pytest.raises(UnstableModelError, match="refused"):
        fit_narma(current_A=I, T_C=T, orders=NarmaOrders(1, 1, 0, 0), period_s=0.01, T_ref_C=25.0)


@pytest.mark.parametrize(
    "bad, msg",
    [
        (dict(current_A=np.ones(10)), "different lengths"),
        (dict(T_C=np.r_[np.full(999, 25.0), np.nan]), "finite"),
        (dict(current_A=np.zeros(30), T_C=np.full(30, 25.0)), "at least"),
    ],
)
def test_fit_rejects_bad_data(bad, msg):
    args = dict(current_A=prbs(1000, seed=0), T_C=np.full(1000, 25.0), orders=NarmaOrders(), period_s=0.01)
    args.update(bad)
    with pytest.raises(ValueError, match=msg):
        fit_narma(**args)


def test_model_validates_its_fields(true_model):
    with pytest.raises(ValueError, match="theta has"):
        NarmaModel(
            orders=NarmaOrders(3, 3, 3, 3),
            theta=np.zeros(5),
            period_s=0.01,
            T_ref_C=25,
            current_range_A=(0, 1),
            T_range_C=(0, 1),
        )
    with pytest.raises(ValueError, match="period_s"):
        NarmaModel(
            orders=TRUE_ORDERS,
            theta=TRUE_THETA,
            period_s=0.0,
            T_ref_C=25,
            current_range_A=(0, 1),
            T_range_C=(0, 1),
        )
    assert not true_model.theta.flags.writeable
    assert math.isclose(true_model.theta_a[0, 0], 1.6) and math.isclose(true_model.theta_b[1, 1], 0.01)


def test_predictor_snapshot_and_restore_replay_exactly(true_model):
    """The control core carries the predictor through pure steps with snapshot()/restore()."""
    I = prbs(300, amplitude_A=(0.1, 1.5), hold_samples=5, seed=8)
    pred = true_model.predictor(26.0)
    for i in I[:100]:
        pred.step(i)
    snap = pred.snapshot()
    first = [pred.step(i) for i in I[100:]]
    pred.restore(snap)
    assert [pred.step(i) for i in I[100:]] == first
    other = NarmaModel(
        orders=NarmaOrders(3, 3, 1, 1),
        theta=np.zeros(12),
        period_s=0.01,
        T_ref_C=25.0,
        current_range_A=(-1, 1),
        T_range_C=(20, 30),
    ).predictor(25.0)
    with pytest.raises(ValueError, match="other orders"):
        other.restore(snap)


@settings(max_examples=40, deadline=None)
@given(
    a0=st.floats(0.5, 0.9995),
    a1=st.floats(-0.3, 0.3),
    b0=st.floats(0.001, 0.5),
    hold=st.sampled_from([1, 10, 100]),
    seed=st.integers(0, 1000),
)
@example(a0=0.9995, a1=0.0, b0=0.5, hold=100, seed=1)  # steady states of ±1000 °C
@example(a0=0.9, a1=0.0999, b0=0.05, hold=100, seed=2)  # the pole nears 1 only at heating currents
def test_a_first_order_free_run_stays_in_the_hull_of_its_steady_states(a0, a1, b0, hold, seed):
    """The stability check's bound (2 x the largest steady-state excursion): with the pole a(I) = a0 + a1·I in
    [0, 1) over the current range, each step is a convex combination of the last temperature and the held
    current's steady state, so a free run on any drive stays in the hull of the steady states, and a model
    with steady states of hundreds of °C (a module that runs away in free air) is accepted."""
    a_edge = max(a0 + a1, a0 - a1)
    assume(0.0 <= min(a0 + a1, a0 - a1) and a_edge <= 1.0 - 2e-6)
    m = NarmaModel(
        orders=NarmaOrders(n=1, m=1, p=1, q=0),
        theta=np.array([a0, a1, b0]),
        period_s=0.01,
        T_ref_C=25.0,
        current_range_A=(-1.0, 1.0),
        T_range_C=(20.0, 30.0),
    )
    steady = m.steady_state_C(np.linspace(-1.0, 1.0, 4001)) - 25.0
    u = prbs(5000, amplitude_A=(0.0, 1.0), hold_samples=hold, seed=seed)
    dev = m.free_run(current_A=u, T0_C=25.0) - 25.0
    span = float(steady.max() - steady.min())
    assert steady.min() - 1e-3 * span <= dev.min() and dev.max() <= steady.max() + 1e-3 * span
    rep = check_stability(m)
    assert rep.stable, rep.reason
    assert rep.bound_C >= 2.0 * float(np.max(np.abs(steady))) * 0.999
