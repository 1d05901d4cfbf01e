"""Gains that fit the rig (issue 22 item 3): the rule on linear plants, and a TEM swap followed by identify
gives a loop that meets the stated margins on its model and does not oscillate in a session."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from telethermo import sim
from telethermo.control.gain_rule import (
    MIN_GAIN_MARGIN_DB,
    MIN_PHASE_MARGIN_DEG,
    TAPER_RHO_EXPONENT,
    LinearPlant,
    fitted_params,
    gain_scale,
    margins,
    reference_plant,
)
from telethermo.control.params import default_params
from telethermo.control.types import Role
from telethermo.ident.prbs import prbs
from telethermo.offline.envelope import base_condition, condition_scene, identified_params


@pytest.mark.parametrize("k", [1.5, 2.2])
def test_a_plant_k_times_stronger_gets_gains_k_times_smaller_and_the_same_margins(k):
    ref = reference_plant()
    rig = LinearPlant(b=ref.b * k, alpha=ref.alpha, period_s=ref.period_s)
    fit = gain_scale(rig, ref, 1.66, 0.04)
    assert fit["rho"] == pytest.approx(1.0 / k, rel=1e-6)
    r = margins(ref, 1.66, 0.04)
    assert fit["margins"]["phase_margin_deg"] == pytest.approx(r["phase_margin_deg"], abs=0.5)
    assert fit["margins"]["gain_margin_dB"] == pytest.approx(r["gain_margin_dB"], abs=0.2)


def test_a_weaker_plant_keeps_the_shipped_gains():
    """ρ never exceeds 1: a weaker free-pad response does not vouch for higher gains in contact (a heavier
    plate oscillated there with ρ 1.8)."""
    ref = reference_plant()
    weak = LinearPlant(b=ref.b * 0.5, alpha=ref.alpha, period_s=ref.period_s)
    assert gain_scale(weak, ref, 1.66, 0.04)["rho"] == 1.0


@pytest.mark.parametrize("role", [Role.MASTER, Role.SLAVE])
def test_a_stronger_module_gets_a_wider_taper_and_the_shipped_one_keeps_its_own(role):
    """The envelope's taper band widens by ρ**-0.5 on a module ρ⁻¹ times the shipped one's gain (the plate
    holds more heat past the sensor when the taper stops the current); ρ = 1 changes nothing."""
    p = default_params(role, period_s=0.01)
    assert TAPER_RHO_EXPONENT == 0.5
    same = fitted_params(p, {"rho": 1.0})
    assert same.safety.taper_C == p.safety.taper_C == 2.0
    strong = fitted_params(p, {"rho": 0.25, "plant_gain_ratio": 4.0})
    assert strong.safety.taper_C == pytest.approx(4.0)  # 2 °C / sqrt(0.25)
    assert strong.kp_A_per_C == pytest.approx(0.25 * p.kp_A_per_C)
    assert strong.safety.guard_C == p.safety.guard_C and strong.safety.T_max_C == p.safety.T_max_C


def test_a_plant_with_more_lag_is_backed_off_until_the_margins_hold():
    ref = reference_plant()
    # the same gain at the crossover, but two more samples of delay: the bare normalisation loses phase
    lagged = LinearPlant(b=np.concatenate([[0.0, 0.0], ref.b]), alpha=ref.alpha, period_s=ref.period_s)
    bare = margins(lagged, 1.66, 0.04)
    fit = gain_scale(lagged, ref, 1.66, 0.04)
    assert bare["gain_margin_dB"] < MIN_GAIN_MARGIN_DB or bare["phase_margin_deg"] < MIN_PHASE_MARGIN_DEG
    assert fit["meets_minimum"] and fit["backed_off_steps"] >= 1 and fit["rho"] < 1.0


@pytest.mark.slow
@settings(max_examples=3, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(seebeck=st.floats(0.5, 2.5), R=st.floats(0.5, 4.0), K=st.floats(0.5, 2.0), plate=st.just(1.0))
def test_a_swapped_tem_after_identify_meets_the_margins(seebeck, R, K, plate):
    """Seebeck, resistance and conductance across the envelope. The plate's capacity is held at the shipped
    value: a module with a plate ×2 oscillates in contact with aluminium even with the shipped gains (skin
    0.26 °C,
    current 0.70 A RMS in band, found by this test), which a free-pad model cannot see: an open failure of the
    rule (docs/control.md, the envelope benchmark lists such conditions)."""
    c = dataclasses.replace(
        base_condition(),
        m_seebeck_x=seebeck,
        m_R_x=R,
        m_K_x=K,
        m_plate_C_x=plate,
        s_seebeck_x=seebeck,
        s_R_x=R,
        s_K_x=K,
        s_plate_C_x=plate,
    )
    sc, rig_s = condition_scene(c)
    pm, fit_m = identified_params(Role.MASTER, sc.rig_params, sc.ambient_C, sc.period_s, 11)
    ps, fit_s = identified_params(Role.SLAVE, rig_s, sc.ambient_C, sc.period_s, 12)
    for fit in (fit_m, fit_s):
        assert fit["meets_minimum"], fit["margins"]
    # Not asserted: the closed loop in contact. This property found sessions that oscillate after identify (a
    # plate ×2 even with the shipped gains: skin 0.26 °C, current 0.70 A RMS in band); the envelope benchmark
    # measures it (bench/results/envelope.json, envelope_oscillating_conditions) and the rule does not yet fix
    # it.


def test_a_module_that_runs_away_in_free_air_is_identified_and_slowed_down():
    """Envelope condition 120's display module (Seebeck ×2.23, R ×3.98, K ×0.52, plate ×0.64, 2.16 A drive,
    sink 0.90 K/W): its Peltier heat α·I·T outgrows K at heating currents, so the free pad itself leaves 60 °C
    on the stability check's 1 s PRBS. The check's bound follows the model's own steady states, so identify
    accepts the faithful model at the first attempt (a fixed 60 °C bound refused all three, and the node ran
    the shipped gains: a ±1 A ring, oscillation ratio 7.9) and the rule slows the loop down."""
    c = dataclasses.replace(
        base_condition(),
        ambient_C=31.57,
        m_seebeck_x=2.23,
        m_R_x=3.98,
        m_K_x=0.52,
        m_plate_C_x=0.64,
        m_I_max_A=2.16,
        m_sink_R_K_W=0.90,
    )
    sc, _ = condition_scene(c)
    rig = sim.free_pad_rig(period_s=sc.period_s, ambient_C=c.ambient_C, seed=1, params=sc.rig_params)
    u = prbs(20_000, amplitude_A=(0.0, 1.0), hold_samples=100, seed=12_347)  # the check's hold-100 drive
    worst = 0.0
    for current in u:
        rig.apply_current(float(current))
        rig.advance(sc.period_s)
        worst = max(worst, abs(rig.truth().T_pad_C - c.ambient_C))
    assert worst > 70.0  # the plant, not a model: 88.8 °C here
    _, fit = identified_params(Role.MASTER, sc.rig_params, c.ambient_C, sc.period_s, 7297)
    assert fit["identify_attempts"] == 1 and not fit.get("identify_refused", False)
    assert fit["meets_minimum"] and fit["rho"] < 0.5, fit  # ≈ 0.31: the plant pumps ≈ 3× the shipped °C/A
