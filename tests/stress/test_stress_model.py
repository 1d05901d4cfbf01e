"""Fast subset of the identified-model stress cases (tests/stress/cases/model.py)."""

import pytest

from tests.stress.cases import model as s
from tests.stress.cases.case import assert_passed

pytestmark = pytest.mark.stress


def test_unstable_models_refused_with_reason():
    r = s.case_unstable_refused()
    assert_passed(r)
    assert "diverged" in r["figures"]["switching_unstable_reason"]


def test_free_run_quarter_hour_bounded_and_drift_free():
    r = s.case_free_run_24h(hours=0.25)
    assert_passed(r)
    assert r["figures"]["samples"] == 90_000
