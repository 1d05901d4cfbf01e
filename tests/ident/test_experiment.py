"""Identification on the simulated rigs (sim/): held-out free-run error, flux error, capacity model,
the shipped model against the current simulator, the safety guard."""

import numpy as np
import pytest

from telethermo import sim
from telethermo.ident import NarmaOrders, default_model_path, load_model, prbs
from telethermo.ident.experiment import (
    ExperimentSettings,
    identify_capacity,
    identify_rig,
    run_excitation,
    steady_state_points,
)


@pytest.fixture(scope="module")
def order3():
    rig = sim.free_pad_rig(period_s=0.01, ambient_C=25.0, seed=0, noise=True)
    return identify_rig(rig, n_samples=10_000, orders=NarmaOrders(3, 3, 3, 3), seed=0)


def test_order3_heldout_free_run_error_within_paper_bound(order3):
    """guiatni §3.3: n = m = p = q = 3, PRBS at 0.01 s, M = 10,000: worst case 0.3 °C. Ours, on a
    held-out PRBS (free run from the start of the experiment), must not be worse."""
    tem, rep = order3
    assert rep["stable"] and rep["guard_interventions"] == 0
    assert rep["heldout_free_run_max_C"] <= 0.3
    assert rep["heldout_free_run_rms_C"] <= 0.1
    # the excitation really moved the pad: errors are small against a swing of several °C
    assert rep["T_range_C"][1] - rep["T_range_C"][0] > 8.0
    assert tem.temperature.T_ref_C == pytest.approx(25.0, abs=0.02)  # ambient of the rig
    assert abs(rep["rest_drift_C"]) < 0.01


def test_flux_model_heldout_error(order3):
    """Heat flux on the held-out PRBS: comparable to guiatni's 0.0025 W worst case (the sensor noise
    alone, σ ≈ 0.0007 W after the filter, gives ~0.003 W worst case over 5000 samples)."""
    tem, rep = order3
    assert rep["flux_heldout_max_W"] <= 0.005
    assert rep["flux_heldout_rms_W"] <= 0.0015
    assert np.max(np.abs(tem.flux.poles())) < 1.0


def test_least_squares_alone_also_meets_the_paper_bound():
    rig = sim.free_pad_rig(seed=3)
    tem, rep = identify_rig(rig, n_samples=10_000, orders=NarmaOrders(3, 3, 3, 3), seed=3, method="ls")
    assert rep["heldout_free_run_max_C"] <= 0.3


def test_shipped_model_predicts_the_current_simulator_within_target():
    """The shipped model (telethermo/data/models/sim_tem.json) on a fresh rig and a PRBS it never saw
    (other seed, other noise): free run from rest, worst case <= 0.1 °C (the issue's target). Also fails
    if the simulator changed since the model was identified."""
    tem = load_model(default_model_path(), expect_period_s=0.01)
    rig = sim.free_pad_rig(period_s=0.01, ambient_C=25.0, seed=11, noise=True)
    u = np.concatenate([np.zeros(200), prbs(8000, amplitude_A=(0.1, 1.0), hold_samples=25, seed=1234)])
    rec = run_excitation(rig, u)
    fr = tem.temperature.free_run(current_A=rec.current_A, T0_C=tem.temperature.T_ref_C)
    err = np.abs(fr - rec.T_C)[200:]
    assert err.max() <= 0.1
    # the streaming predictor a node runs gives the same numbers
    pred = tem.temperature.predictor(tem.temperature.T_ref_C)
    stream = np.array([pred.T_pred_C] + [pred.step(i) for i in rec.current_A[:-1]])
    assert np.max(np.abs(stream - fr)) < 1e-6  # same recursion, other rounding order
    q = tem.flux.free_run(T_C=rec.T_C, current_A=rec.current_A)
    assert np.max(np.abs(q - rec.Q_W)[200:]) <= 0.006


def test_capacity_model_within_2_percent_of_simulator_steady_state():
    """Eq. 13 from 14 steady states (currents limited to a safe steady state: on a pad in air ±1.5 A
    would settle at -24 °C / 167 °C); checked at 13 held-out currents (midpoints) against the
    simulator's true steady-state flux: max error <= 2 % of the largest |P|."""
    tem = load_model(default_model_path())
    rig = sim.free_pad_rig(seed=5)
    cap, ss = identify_capacity(rig, tem.temperature)
    assert len(ss.current_A) == 14 and ss.skipped == []
    assert np.all((ss.T_C > 16.0) & (ss.T_C < 42.0))
    mid = 0.5 * (ss.current_A[1:] + ss.current_A[:-1])
    held = steady_state_points(sim.free_pad_rig(seed=6), mid)
    P = cap.predict(current_A=held.current_A, T_C=held.T_C)
    assert np.max(np.abs(P - held.Q_true_W)) <= 0.02 * np.max(np.abs(held.Q_true_W))
    assert np.max(np.abs(held.Q_true_W)) > 0.02  # a real flux, not noise


def test_safety_guard_keeps_the_pad_inside_the_envelope():
    """A PRBS biased to heat (+0.6 A mean) would drive the free pad far above 43 °C; the guard flips
    the current near the envelope and counts it."""
    rig = sim.free_pad_rig(seed=2)
    settings = ExperimentSettings()
    u = prbs(6000, amplitude_A=(0.2, 0.6), hold_samples=25, seed=9, offset_A=0.6)
    rec = run_excitation(rig, u, settings=settings)
    assert rec.guard_interventions > 0
    assert rec.T_C.max() <= settings.T_max_C
    assert np.max(np.abs(rec.current_A)) <= 0.8 * rig.I_max_A


@pytest.mark.parametrize(
    "kwargs, field",
    [
        (dict(hold_samples=0), "hold_samples"),
        (dict(amplitude_A=(1.0, 0.5)), "amplitude_A"),
        (dict(current_limit_fraction=1.5), "current_limit_fraction"),
        (dict(T_min_C=40.0, T_max_C=41.0), "T_max_C"),
        (dict(capacity_points=3), "capacity_points"),
    ],
)
def test_experiment_settings_are_validated(kwargs, field):
    with pytest.raises(ValueError, match=f"ExperimentSettings.{field}: expected"):
        ExperimentSettings(**kwargs)
