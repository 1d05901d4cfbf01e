"""Property tests (hypothesis): the streaming predictor is the free run; model files round-trip."""

import numpy as np
from hypothesis import given, settings, strategies as st

from telethermo.ident import NarmaModel, NarmaOrders, TemModel
from telethermo.ident.modelfile import model_from_dict, model_to_dict


@st.composite
def stable_models(draw):
    n, m = draw(st.integers(1, 4)), draw(st.integers(1, 4))
    p, q = draw(st.integers(0, 3)), draw(st.integers(0, 3))
    o = NarmaOrders(n, m, p, q)
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    poles = rng.uniform(-0.9, 0.95, size=n)  # real poles inside the unit circle at I = 0
    alpha0 = -np.poly(poles)[1:]  # z^n - Σ α_i z^(n-i)
    ta = np.zeros((n, p + 1))
    ta[:, 0] = alpha0
    if p:
        ta[:, 1:] = rng.normal(scale=1e-3, size=(n, p))  # weak current dependence
    tb = rng.normal(scale=0.05, size=(m, q + 1))
    return NarmaModel(
        orders=o,
        theta=np.r_[ta.ravel(), tb.ravel()],
        period_s=0.01,
        T_ref_C=25.0,
        current_range_A=(-1.0, 1.0),
        T_range_C=(20.0, 30.0),
    )


@settings(max_examples=30, deadline=None)
@given(model=stable_models(), seed=st.integers(0, 1000), T0=st.floats(15.0, 40.0))
def test_streaming_predictor_equals_free_run(model, seed, T0):
    u = np.random.default_rng(seed).uniform(-1.2, 1.2, size=200)  # also outside the range: clamped alike
    fr = model.free_run(current_A=u, T0_C=T0)
    pred = model.predictor(T0)
    stream = np.array([pred.T_pred_C] + [pred.step(i) for i in u[:-1]])
    assert np.allclose(stream, fr, rtol=0, atol=1e-9 * max(1.0, np.max(np.abs(fr))))


@settings(max_examples=25, deadline=None)
@given(model=stable_models())
def test_model_document_round_trip(model):
    tem = TemModel(temperature=model, meta={"k": 1})
    back = model_from_dict(model_to_dict(tem), check_stability=False)
    assert np.array_equal(back.temperature.theta, model.theta)
    assert back.temperature.orders == model.orders and back.meta == {"k": 1}
