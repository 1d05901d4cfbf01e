"""The material fit's small least-squares solver against numpy's, on badly scaled and collinear columns."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from telethermo.control import material_id as mi
from telethermo.control.small_lstsq import NormalEquations


def _problem(seed: int, scales: np.ndarray, n: int = 30) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((n, scales.size)) * scales
    theta = rng.uniform(0.5, 2.0, scales.size) / scales
    return X, X @ theta + 1e-3 * rng.standard_normal(n), theta


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31), exps=st.lists(st.integers(-9, 4), min_size=3, max_size=3))
def test_the_solution_and_covariance_match_lstsq_whatever_the_units(seed: int, exps: list[int]) -> None:
    """Columns whose units differ by up to 13 decades (the material fit's differ by about 8): θ and (XᵀX)⁻¹
    equal numpy's SVD-based least squares of the same problem in unit-scaled columns to 1e-9 relative, for
    three columns and for the first two."""
    scales = 10.0 ** np.array(exps, float)
    X, y, _ = _problem(seed, scales)
    normal = NormalEquations(X, y)
    for cols in (3, 2):
        solved = normal.solve(cols)
        assert solved is not None
        theta, cov = np.array(solved[0]), np.array(solved[1])
        Xs = X[:, :cols] / scales[:cols]  # the reference, computed where it is well conditioned (numpy on
        # the raw columns loses up to eps·cond(X) ≈ 1e-9 there itself)
        ref = np.linalg.lstsq(Xs, y, rcond=None)[0] / scales[:cols]
        assert np.allclose(theta, ref, rtol=1e-9, atol=0.0)
        ref_cov = np.linalg.inv(Xs.T @ Xs) / np.outer(scales[:cols], scales[:cols])
        assert np.allclose(cov, ref_cov, rtol=1e-9, atol=0.0)


def test_collinear_columns_and_bad_input_give_none() -> None:
    X, y, _ = _problem(3, np.ones(3))
    X[:, 2] = 2.0 * X[:, 0] + 1e-9 * X[:, 1]  # collinear to 1e-9: beyond the solver's accepted condition
    normal = NormalEquations(X, y)
    assert normal.solve(3) is None and normal.solve(2) is not None
    X[:, 1] = 0.0
    assert NormalEquations(X, y).solve(2) is None  # a zero column
    X, y, _ = _problem(4, np.ones(3))
    y[5] = np.nan
    assert NormalEquations(X, y).solve(3) is None
    with pytest.raises(ValueError, match="cols"):
        NormalEquations(*_problem(5, np.ones(3))[:2]).solve(4)


def test_a_noise_realisation_is_drawn_once_read_only_and_as_documented() -> None:
    """The cached realisation equals a fresh draw of the documented recipe (seeded (seed, k), filtered from
    rest over 50 extra samples), is the same object on the next call and cannot be written."""
    p = mi.ProbeParams()
    args = (p.noise_seed, 3, 35, p.T_sigma_C, p.Q_sigma_W, p.cutoff_Hz, 0.01)
    nT, nQ = mi.noise_realisation(*args)
    rng = np.random.default_rng((p.noise_seed, 3))
    ref_T = mi.lowpass(p.T_sigma_C * rng.standard_normal(85), p.cutoff_Hz, 0.01)[50:]
    ref_Q = mi.lowpass(p.Q_sigma_W * rng.standard_normal(85), p.cutoff_Hz, 0.01)[50:]
    assert np.array_equal(nT, ref_T) and np.array_equal(nQ, ref_Q)
    assert mi.noise_realisation(*args)[0] is nT
    with pytest.raises(ValueError):
        nT[0] = 1.0
    assert 0.3 * p.T_sigma_C < float(np.std(nT)) < p.T_sigma_C  # the 5 Hz filter keeps part of the noise
