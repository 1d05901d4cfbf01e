"""PI + feed-forward: anti-windup including the feed-forward, bumpless re-seeding, components."""

import math

import pytest
from hypothesis import given, settings, strategies as st

from telethermo.control.pi import FluxPIGains, PIGains, PIState, bumpless, pi_step

G = PIGains(kp_A_per_C=0.5, ki_A_per_C_s=2.0)


def test_unsaturated_law_is_eq33():
    u, s, c = pi_step(G, PIState(0.1), error_C=0.4, ff_A=0.3, dt_s=0.01, u_min_A=-2, u_max_A=2)
    assert math.isclose(c.p_A, 0.2)
    assert math.isclose(s.integral_A, 0.1 + 2.0 * 0.4 * 0.01)
    assert math.isclose(u, 0.2 + 0.108 + 0.3)
    assert not c.saturated and c.u_unsat_A == u


def test_integrator_does_not_wind_up_behind_feedforward():
    # a feed-forward that alone saturates the output: a positive error must not charge the integrator
    s = PIState(0.0)
    for _ in range(1000):
        u, s, c = pi_step(G, s, error_C=1.0, ff_A=1.9, dt_s=0.01, u_min_A=-1.6, u_max_A=1.6)
        assert u == 1.6
    # integral kept such that p + i + ff <= u_max (here negative: the ff already exceeds the limit)
    assert s.integral_A <= 1.6 - 0.5 - 1.9 + 1e-12
    # when the error reverses, the output leaves saturation at once (no windup to unwind)
    u, s, c = pi_step(G, s, error_C=-1.0, ff_A=0.0, dt_s=0.01, u_min_A=-1.6, u_max_A=1.6)
    assert u < 0.0


def test_integrator_windup_free_under_plain_saturation():
    s = PIState(0.0)
    for _ in range(5000):
        u, s, _ = pi_step(G, s, error_C=10.0, ff_A=0.0, dt_s=0.01, u_min_A=-1.0, u_max_A=1.0)
    assert u == 1.0
    assert s.integral_A <= 1.0 - 5.0 + 1e-12 or s.integral_A <= 1.0
    # one step of small negative error: the output drops below the limit immediately
    u2, _, _ = pi_step(G, s, error_C=-0.01, ff_A=0.0, dt_s=0.01, u_min_A=-1.0, u_max_A=1.0)
    assert u2 < 1.0


@settings(max_examples=200, deadline=None)
@given(
    u_prev=st.floats(-1.5, 1.5),
    e=st.floats(-20, 20),
    ff=st.floats(-1, 1),
    kp=st.floats(0, 0.5),
    ki=st.floats(0, 10),
)
def test_bumpless_reseed_gives_continuous_output(u_prev, e, ff, kp, ki):
    g = PIGains(kp, ki)
    s = bumpless(g, u_prev, e, ff, -1.6, 1.6)
    # the next output with zero integration time equals the previous output whenever reachable
    u, _, c = pi_step(g, s, e, ff, 0.0, -1.6, 1.6)
    if -1.6 <= u_prev - kp * e - ff <= 1.6:
        assert math.isclose(u, u_prev, abs_tol=1e-9)
    assert -1.6 <= u <= 1.6


@settings(max_examples=300, deadline=None)
@given(
    e=st.one_of(st.floats(allow_nan=True, allow_infinity=True)),
    ff=st.floats(allow_nan=True, allow_infinity=True),
    i0=st.floats(-3, 3),
)
def test_output_always_finite_and_within_limits(e, ff, i0):
    u, s, _ = pi_step(G, PIState(i0), e, ff, 0.01, -1.6, 1.6)
    assert math.isfinite(u) and -1.6 <= u <= 1.6 and math.isfinite(s.integral_A)


def test_the_flux_loop_gains_are_in_amperes_per_watt():
    fg = FluxPIGains(kp_A_per_W=0.5, ki_A_per_W_s=2.0)
    u, st, c = pi_step(
        PIGains(0.0, 0.0), PIState(), 0.0, 0.0, 0.01, -3.0, 3.0, flux_error_W=0.4, flux_gains=fg
    )
    assert c.p_A == pytest.approx(0.5 * 0.4) and st.integral_A == pytest.approx(2.0 * 0.4 * 0.01)
    assert u == pytest.approx(0.2 + 0.008)
    # bumpless re-seeding counts the flux loop's proportional term too
    assert bumpless(
        PIGains(0.0, 0.0), 1.0, 0.0, 0.0, -3.0, 3.0, flux_error_W=0.4, flux_gains=fg
    ).integral_A == pytest.approx(1.0 - 0.2)
    with pytest.raises(ValueError, match="FluxPIGains.kp_A_per_W"):
        FluxPIGains(-1.0, 0.0)
