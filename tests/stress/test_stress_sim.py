"""Fast subset of the simulator stress cases (tests/stress/cases/sim.py)."""

import pytest

from tests.stress.cases import sim as s
from tests.stress.cases.case import assert_passed

pytestmark = pytest.mark.stress


def test_extreme_materials_maximum_principle_and_energy():
    assert_passed(s.case_extreme_materials(duration_s=10.0))


def test_many_touches_contact_flags_and_energy():
    r = s.case_many_touches(n_touches=500)
    assert_passed(r)
    assert r["figures"]["contact_samples"] == 1500


def test_one_ms_chatter():
    assert_passed(s.case_chatter(duration_s=0.5))


def test_force_steps_move_the_heat_flow():
    assert_passed(s.case_force_steps(n_steps=8))


def test_short_soak_energy_balanced():
    assert_passed(s.case_soak(hours=0.05))
