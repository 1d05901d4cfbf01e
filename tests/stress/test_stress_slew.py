"""Fast subset of the surface-rate-around-trips case (tests/stress/cases/slew.py)."""

import pytest

from tests.stress.cases import slew as s
from tests.stress.cases.case import assert_passed

pytestmark = pytest.mark.stress


def test_peer_trip_in_a_cold_contact_keeps_the_surface_within_ramp_plus_one():
    res = s.case_surface_rate(
        contacts=("cold_al_18C",), events=("peer_lost_no_fallback", "sensor_nan"), after_touch_s=(2.0,)
    )
    assert_passed(res)
    rows = {r["event"]: r for r in res["figures"]["surface_rate_cases"]}
    # the case can fail: the code path before the slew moves the surface faster than the bound here
    assert rows["peer_lost_no_fallback"]["rate_before_C_per_s"] > s.RATE_LIMIT_C_PER_S
    assert rows["peer_lost_no_fallback"]["rate_slew_C_per_s"] <= s.RATE_LIMIT_C_PER_S
    assert res["headline"]["surface_rate_limit_C_per_s"] == 6.0


def test_link_loss_fallback_start_in_a_warm_touch_keeps_the_surface_within_ramp_plus_one():
    """The fallback replaces telepresence's feed-forward and flux terms in one step, as a peer trip does: the
    envelope slews and lead-bounds it the same way (before: 8.2 °C/s in a 40 °C oak touch moving at 2.6
    alone).
    0.7 s into the touch: the slave's identification (0.3 s window + its staged fit) has reached the master,
    so
    the fallback starts (lost earlier, the master has no material to render and the peer trip acts at
    once)."""
    res = s.case_surface_rate(contacts=("warm_wood_40C",), events=("peer_lost",), after_touch_s=(0.7,))
    assert_passed(res)
    (row,) = res["figures"]["surface_rate_cases"]
    assert row["trip_after_s"] > 1.0  # the fallback ran before the trip
    assert row["rate_fallback_no_event_C_per_s"] < s.RATE_LIMIT_C_PER_S
    assert row["rate_fallback_before_C_per_s"] > s.RATE_LIMIT_C_PER_S  # the case can fail
    assert row["rate_fallback_C_per_s"] <= s.RATE_LIMIT_C_PER_S
