"""Fast subset of the control-core stress cases (tests/stress/cases/control.py)."""

import pytest

from tests.stress.cases import control as s
from tests.stress.cases.case import assert_passed

pytestmark = pytest.mark.stress


def test_bad_peer_values_keep_the_envelope():
    assert_passed(
        s.case_bad_peer(
            healthy_s=2.0,
            bad_s=8.0,
            kinds=(
                "nan_estimate",
                "-inf_estimate",
                "1e30_estimate",
                "inf_flux",
                "90C_estimate_plausible",
                "peer_lost",
                "none",
            ),
        )
    )


def test_saturation_then_release_no_windup_kick():
    assert_passed(s.case_saturation_release(saturate_s=30.0, after_s=10.0))


def test_sync_loss_and_bursts():
    assert_passed(s.case_sync_loss_bursts(duration_s=20.0))


def test_real32_rounding_not_amplified():
    assert_passed(s.case_real32(duration_s=3.0))
