"""The probe's flux-loop gain bound (issue 22 experiment, telethermo/control/flux_bound.py): it falls with the
exchange's delay, scales inversely with the identified model's gain, and the loop it gives has the stated
phase margin at its crossover."""

from __future__ import annotations

import math

import numpy as np
import pytest

from telethermo.control.flux_bound import (
    PHASE_MARGIN_DEG,
    ZERO_BELOW_CROSSOVER,
    flux_gain_bound,
    loop_lag_s,
)
from telethermo.control.gain_rule import LinearPlant, reference_plant

KPQ_REF_A_PER_W = 0.258


def test_the_bound_falls_with_the_delay_and_is_the_reference_gain_without_delay():
    ref = reference_plant()
    kp = [flux_gain_bound(ref, ref, d, KPQ_REF_A_PER_W)["kpQ_A_per_W"] for d in (0.0, 0.025, 0.05, 0.1)]
    assert kp[0] == pytest.approx(KPQ_REF_A_PER_W, rel=1e-9)
    assert all(b < a for a, b in zip(kp, kp[1:]))
    # the pad is an integrator near the crossover, so kpQ falls with f_c; not quite as 1/T_loop, since the
    # pad's own lag beyond the integrator's 90° takes a share of the phase that does not grow with the delay
    lag_ratio = loop_lag_s(0.0, 0.01, 1.1) / loop_lag_s(0.1, 0.01, 1.1)
    assert lag_ratio <= kp[-1] / kp[0] < 1.0


@pytest.mark.parametrize("k", [1.5, 2.5])
def test_a_plant_k_times_stronger_gets_a_gain_k_times_smaller(k):
    ref = reference_plant()
    rig = LinearPlant(b=ref.b * k, alpha=ref.alpha, period_s=ref.period_s)
    for d in (0.0, 0.06):
        a = flux_gain_bound(ref, ref, d, KPQ_REF_A_PER_W)
        b = flux_gain_bound(rig, ref, d, KPQ_REF_A_PER_W)
        assert b["kpQ_A_per_W"] == pytest.approx(a["kpQ_A_per_W"] / k, rel=1e-6)
        assert b["crossover_Hz"] == pytest.approx(a["crossover_Hz"])  # the same phase: the same crossover


def test_the_rule_never_raises_the_gain_above_the_gain_rules_scaling():
    ref = reference_plant()
    weak = LinearPlant(b=ref.b * 0.5, alpha=ref.alpha, period_s=ref.period_s)
    assert flux_gain_bound(weak, ref, 0.0, KPQ_REF_A_PER_W, rho=1.0)["kpQ_A_per_W"] == KPQ_REF_A_PER_W
    assert flux_gain_bound(ref, ref, 0.0, KPQ_REF_A_PER_W, rho=0.3)["kpQ_A_per_W"] == pytest.approx(
        0.3 * 0.258
    )


@pytest.mark.parametrize("delay_s", [0.0, 0.05, 0.1])
def test_the_loop_through_the_exchange_crosses_at_the_bound_with_the_stated_margin(delay_s):
    """L(f) = kpQ·K_f·G(f)·e^(−j2πf·T_loop)·(1 + f_z/(jf)), K_f eliminated by the reference: |L| = 1 at the
    crossover the bound reports, and the phase there leaves PHASE_MARGIN_DEG."""
    ref = reference_plant()
    rig = LinearPlant(b=ref.b * 1.8, alpha=ref.alpha, period_s=ref.period_s)
    b = flux_gain_bound(rig, ref, delay_s, KPQ_REF_A_PER_W)
    K_f_W_per_K = 1.0 / (KPQ_REF_A_PER_W * abs(complex(ref.response(b["reference_crossover_Hz"]))))
    f = b["crossover_Hz"]
    f_z = b["kiQ_A_per_W_s"] / (2 * math.pi * b["kpQ_A_per_W"])
    assert f_z == pytest.approx(f / ZERO_BELOW_CROSSOVER)
    L = (
        b["kpQ_A_per_W"]
        * K_f_W_per_K
        * complex(rig.response(f))
        * np.exp(-2j * np.pi * f * b["loop_lag_s"])
        * (1 + f_z / (1j * f))
    )
    assert abs(L) == pytest.approx(abs(1 + 0.1j), rel=0.01)  # |P·K_f·G| = 1; the PI's zero adds 0.5 %
    assert 180.0 + math.degrees(np.angle(L)) == pytest.approx(PHASE_MARGIN_DEG, abs=1.0)
