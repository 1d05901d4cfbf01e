"""The peer link: fresh/missed/alive bookkeeping the control core relies on."""

from __future__ import annotations

import math

from telethermo.nodes.peer import PeerLink


def test_none_until_first_pdo_then_fresh_values():
    link = PeerLink(max_missed_cycles=3)
    assert link.take() is None
    link.on_pdo(30.5, -0.25)
    pv = link.take()
    assert (pv.estimate_C, pv.flux_W, pv.fresh, pv.alive) == (30.5, -0.25, True, True)
    pv = link.take()
    assert pv.fresh is False and pv.alive is True and pv.estimate_C == 30.5


def test_missing_pdos_declare_the_peer_lost_and_a_pdo_brings_it_back():
    link = PeerLink(max_missed_cycles=3)
    link.on_pdo(30.0, 0.0)
    link.take()
    alive = [link.take().alive for _ in range(5)]
    assert alive == [True, True, True, False, False]
    assert link.counters.losses == 1
    link.on_pdo(31.0, 0.1)
    pv = link.take()
    assert pv.alive and pv.fresh and pv.estimate_C == 31.0
    assert link.counters.returns == 1


def test_heartbeat_timeout_overrides_fresh_pdos():
    link = PeerLink()
    link.on_pdo(30.0, 0.0)
    link.on_heartbeat_timeout()
    assert link.take().alive is False
    link.on_heartbeat()
    link.on_pdo(30.0, 0.0)
    assert link.take().alive is True


def test_nan_is_passed_on_and_counted():
    link = PeerLink()
    link.on_pdo(math.nan, 1.0)
    pv = link.take()
    assert math.isnan(pv.estimate_C) and link.counters.non_finite == 1


def test_stand_in_values_until_the_first_pdo_then_lost_if_none_comes():
    from telethermo.control.types import PeerValues

    link = PeerLink(max_missed_cycles=3)
    link.start_with(PeerValues(30.0, 0.0, fresh=False, alive=True))
    pv = link.take()  # cycle 0: the stand-in, as the offline runner
    assert (pv.estimate_C, pv.flux_W, pv.fresh, pv.alive) == (30.0, 0.0, False, True)
    assert link.counters.missed_cycles == 0
    assert [link.take().alive for _ in range(4)] == [True, True, True, False]
    link.on_pdo(31.0, 0.2)
    assert link.take() == PeerValues(31.0, 0.2, fresh=True, alive=True)
