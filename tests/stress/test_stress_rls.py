"""Fast subset of the RLS stress cases (tests/stress/cases/rls.py): same checks, smaller sizes."""

import pytest

from tests.stress.cases import rls as s
from tests.stress.cases.case import assert_passed

pytestmark = pytest.mark.stress


def test_idle_then_step_bounded_no_jump():
    # 36,000 samples (6 min at 0.01 s): without the constant-trace bound K would grow by 0.999^-36000 ≈ 4e15
    assert_passed(s.case_idle_hour_then_step(n_idle=36_000))


def test_collinear_and_ill_conditioned_regressors():
    assert_passed(s.case_collinear(n=5_000))


def test_forgetting_factors_near_their_bounds():
    assert_passed(s.case_lambda_bounds(n=4_000))


def test_huge_and_tiny_signal_scales():
    assert_passed(s.case_signal_scales(n=5_000))


def test_nonfinite_bursts_rejected_counted_and_harmless():
    r = s.case_nonfinite_bursts(n=5_000)
    assert_passed(r)
    assert r["figures"]["rejected_counted"] == r["figures"]["injected_nonfinite"] > 0
