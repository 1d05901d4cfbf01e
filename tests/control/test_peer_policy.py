"""The peer policy: when the peer is alive, and when a node resumes after the peer's return."""

from __future__ import annotations

import math

from telethermo.control.core import CoreParams, init_state, step
from telethermo.control.peer_policy import PeerResume, peer_alive, peer_back, peer_resume, resume
from telethermo.control.safety import Trip
from telethermo.control.types import Mode, PeerValues, Role
from telethermo.rig import RigSample

LOST, INVALID, SINK = Trip.PEER_LOST, Trip.PEER_INVALID, Trip.HEAT_SINK
BACK = PeerValues(31.0, 0.1, fresh=True, alive=True)


def test_alive_needs_heartbeat_values_and_few_misses():
    assert peer_alive(heartbeat_ok=True, seen=True, missed_cycles=3, max_missed_cycles=3)
    assert not peer_alive(heartbeat_ok=True, seen=True, missed_cycles=4, max_missed_cycles=3)
    assert not peer_alive(heartbeat_ok=False, seen=True, missed_cycles=0, max_missed_cycles=3)
    assert not peer_alive(heartbeat_ok=True, seen=False, missed_cycles=0, max_missed_cycles=3)
    assert peer_alive(
        heartbeat_ok=True, seen=True, missed_cycles=-1, max_missed_cycles=1
    )  # cycle 0's stand-in


def test_back_means_alive_and_fresh():
    assert peer_back(BACK)
    assert not peer_back(None)
    assert not peer_back(PeerValues(31.0, 0.1, fresh=False, alive=True))  # an old value: not back yet
    assert not peer_back(PeerValues(31.0, 0.1, fresh=True, alive=False))  # a PDO, but the heartbeat is lost


def test_resume_only_when_back_and_only_peer_trips_are_latched():
    assert peer_resume(BACK, frozenset({LOST})) is PeerResume.RESUME
    assert peer_resume(BACK, frozenset({LOST, INVALID})) is PeerResume.RESUME
    assert peer_resume(BACK, frozenset({LOST, SINK})) is PeerResume.LATCHED
    assert peer_resume(BACK, frozenset({SINK})) is PeerResume.NONE  # no peer trip: not the peer's business
    assert peer_resume(BACK, frozenset()) is PeerResume.NONE
    stale = PeerValues(31.0, 0.1, fresh=False, alive=True)
    assert peer_resume(stale, frozenset({LOST})) is PeerResume.NONE
    assert peer_resume(None, frozenset({LOST})) is PeerResume.NONE


def test_resume_clears_the_peer_trip_of_a_core_that_lost_its_peer():
    p = CoreParams(role=Role.MASTER, mode=Mode.TELEPRESENCE, kp_A_per_C=0.5, ki_A_per_C_s=2.0, kQ_A_per_W=0.3)
    s = RigSample(0.0, 33.0, 0.0, 0.0, False, 26.0)
    state = init_state(p, None, s)
    lost = PeerValues(math.nan, math.nan, fresh=False, alive=False)
    for k in range(3):
        state = step(RigSample(0.01 * k, 33.0, 0.0, 0.0, False, 26.0), lost, p, state).state
    assert LOST in state.env.trips
    decision = peer_resume(BACK, frozenset(state.env.trips))
    assert decision is PeerResume.RESUME
    new, cleared = resume(s, BACK, p, state)
    assert LOST in cleared and not new.env.trips and not new.env.cut
    assert LOST in state.env.trips  # pure: the old state is untouched
