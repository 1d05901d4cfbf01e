"""The profiled classifier that knows the simulator (telethermo/offline/material_profile.py): its record, its
fit, and why a linearised oracle is kind to the truth."""

from __future__ import annotations

import math

import numpy as np

from telethermo.offline.material_profile import (
    KNOWN_ONSET,
    PRE,
    Fit,
    TouchModel,
    laplace_log_evidence,
    lm_fit,
    record_vector,
    window_block,
)
from telethermo.offline.material_touches import PERIOD_S, finger_natural_C, simulate_touch
from telethermo.sim.measurement import NoiseParams
from telethermo.sim.tem import load_rig_params

PARAMS = load_rig_params()
T_PROBE = finger_natural_C(PARAMS)
N_WIN = 34  # the early answer's window


def _touch(mat: str, force_N: float, thick_m: float, T_o: float) -> tuple[TouchModel, np.ndarray]:
    """A noise-free touch's record and the model of its probe, room and onset (whitening: identity)."""
    T, Q, i0, _, _ = simulate_touch(
        PARAMS,
        mat,
        thick_m,
        T_o,
        force_N,
        T_PROBE,
        seed=0,
        t_on_s=0.205,
        noise=NoiseParams(enabled=False),
        identify=False,
        post_s=0.6,
    )
    v = record_vector(T, Q, i0, N_WIN)
    assert v is not None
    model = TouchModel(PARAMS, None, 25.0, T_PROBE, 0.205, i0, N_WIN, np.eye(2 * N_WIN))
    return model, v


def test_the_record_is_each_signal_s_change_since_the_pre_contact_mean():
    T = np.r_[np.full(PRE, 30.0), np.linspace(29.0, 20.0, 10)]
    Q = np.r_[np.full(PRE, 0.1), np.full(10, 0.6)]
    v = record_vector(T, Q, PRE, 10)
    assert v is not None
    assert np.allclose(v[:10], np.linspace(-1.0, -10.0, 10))
    assert np.allclose(v[10:], 0.5)
    assert record_vector(T, Q, PRE, 11) is None  # the window runs past the record
    assert record_vector(T, Q, PRE - 1, 5) is None  # too few samples before the contact


def test_the_window_block_is_the_first_samples_of_each_signal():
    n = 5
    cov = np.arange(4 * n * n, dtype=float).reshape(2 * n, 2 * n)
    b = window_block(cov, n, 2)
    assert b.shape == (4, 4)
    assert b[0, 2] == cov[0, n] and b[3, 3] == cov[n + 1, n + 1]


def test_the_fit_finds_a_touch_s_force_and_thickness_from_far_off():
    """Aluminium 1.5 mm at 3 N, 15 °C: started at 6 N, 3 mm and 18 °C, the fit on simulated traces comes back
    to within 2 % of the force and thickness and 0.05 °C of the object, its residual a millionth of the
    start's (in °C² and W² of the record, unwhitened)."""
    model, v = _touch("aluminium", 3.0, 1.5e-3, 15.0)
    start = np.array([math.log(6.0), math.log(3e-3), 18.0, 0.0])
    first = float(np.sum((v - model.trace("aluminium", start)) ** 2))
    fit = lm_fit(lambda th: model.trace("aluminium", th), v, start, KNOWN_ONSET, iters=8)
    assert fit.cost < 1e-6 * first
    assert abs(fit.theta[0] - math.log(3.0)) < 0.02
    assert abs(fit.theta[1] - math.log(1.5e-3)) < 0.02
    assert abs(fit.theta[2] - 15.0) < 0.05


def test_the_fit_never_ends_above_its_start():
    """Levenberg–Marquardt keeps a step only when the simulated residual falls: a wrong candidate's fit is no
    worse than its start, whatever the trace."""
    model, v = _touch("glass", 1.0, 0.5e-3, 40.0)
    start = np.array([math.log(1.0), math.log(0.5e-3), 40.0, 0.0])
    at_start = float(np.sum((v - model.trace("copper", start)) ** 2))
    fit = lm_fit(lambda th: model.trace("copper", th), v, start, KNOWN_ONSET, iters=3)
    assert fit.cost <= at_start
    assert fit.sims >= 1 + 3  # the start and at least one Jacobian


def test_onset_within_the_sample_moves_the_trace():
    """Half a sample (5 ms) of onset moves a metal's early record by more than the rig's noise would: the
    slave does not know it (σ_T 0.02 °C; the move is about 0.5 °C), so an oracle that does is kind."""
    model, v = _touch("brass", 8.0, 10e-3, 15.0)
    th = np.array([math.log(8.0), math.log(10e-3), 15.0, 0.0])
    moved = model.trace("brass", th + np.array([0.0, 0.0, 0.0, 0.5 * PERIOD_S]))
    assert np.allclose(model.trace("brass", th), v)
    sigma_T = NoiseParams().T_sigma_C
    assert float(np.max(np.abs(moved[:N_WIN] - v[:N_WIN]))) > 10 * sigma_T


def _fit(cost: float, fisher: np.ndarray, free: list[int]) -> Fit:
    return Fit(cost, np.zeros(4), cost, 1, fisher, np.array(free))


def test_the_evidence_weighs_a_narrow_fit_below_a_broad_one():
    """Two candidates fit the record equally well; the one whose nuisances are pinned to a narrow ridge (high
    information) has the lower Laplace evidence, by ½·ln of the information ratio per pinned direction; a
    direction the record does not inform (a thick slab's thickness) costs nothing; with nothing free the
    evidence is −cost/2."""
    broad = laplace_log_evidence(_fit(300.0, np.diag([1e2, 0.0, 1e2]), [0, 1, 2]))
    narrow = laplace_log_evidence(_fit(300.0, np.diag([1e6, 0.0, 1e2]), [0, 1, 2]))
    assert narrow < broad
    assert math.isclose(broad - narrow, 0.5 * math.log(1e6 / 1e2), rel_tol=1e-9)
    blind = laplace_log_evidence(_fit(300.0, np.diag([1e2, 1e2]), [0, 2]))
    assert math.isclose(blind, broad, rel_tol=1e-12)
    assert laplace_log_evidence(_fit(300.0, np.zeros((0, 0)), [])) == -150.0
