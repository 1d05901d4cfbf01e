"""The peer policy of a bilateral node: when the peer counts as alive, and when a node whose envelope
tripped on the peer's loss resumes telepresence (DESIGN.md §6). Pure: no bus, no clock, no threads.

- The peer is **alive** while its heartbeat is seen, it has sent values (or the cycle-0 stand-in is in
  place) and at most ``max_missed_cycles`` consecutive cycles passed without a fresh PDO
  (:func:`peer_alive`). A lost peer is back when both hold again: heartbeat seen and a fresh PDO.
- A peer loss latches the envelope's peer trips (ramp to neutral, then cut; EMCY 0x8130). When the
  peer is back (alive and fresh this cycle) and **only** peer trips are latched, the node resumes:
  the trips are cleared and the core restarts bumplessly (:func:`peer_resume`, :func:`resume`). Any
  other latched trip keeps the envelope as it is until an operator's fault reset.
"""

from __future__ import annotations

from enum import Enum

from telethermo.control.core import CoreParams, CoreState, clear_faults
from telethermo.control.safety import PEER_TRIPS, Trip
from telethermo.control.types import PeerValues
from telethermo.rig import RigSample


def peer_alive(*, heartbeat_ok: bool, seen: bool, missed_cycles: int, max_missed_cycles: int) -> bool:
    """Whether the peer counts as alive this cycle.

    Args:
        heartbeat_ok: the heartbeat consumer has not reported a timeout since the last heartbeat seen.
        seen: a PDO of the peer (or the cycle-0 stand-in values) has been received.
        missed_cycles: consecutive cycles without a fresh PDO (-1 before cycle 0 with a stand-in).
        max_missed_cycles: the miss limit (object peer_pdo_miss_limit, >= 1).
    """
    return heartbeat_ok and seen and missed_cycles <= max_missed_cycles


class PeerResume(str, Enum):
    """What a node does with its latched trips in a cycle, given its peer's values."""

    NONE = "none"  # the peer is not back, or no peer trip is latched: nothing to do
    RESUME = "resume"  # the peer is back and only peer trips are latched: clear them, resume
    LATCHED = "latched"  # the peer is back but other trips are latched: stay as is until an operator reset


def peer_back(peer: PeerValues | None) -> bool:
    """The peer's values of this cycle show it alive and fresh (a PDO arrived for this cycle)."""
    return peer is not None and bool(peer.alive) and bool(peer.fresh)


def peer_resume(peer: PeerValues | None, trips: frozenset[Trip]) -> PeerResume:
    """The decision for this cycle from the peer's values and the envelope's latched ``trips``."""
    if not peer_back(peer) or not (trips & PEER_TRIPS):
        return PeerResume.NONE
    if trips <= PEER_TRIPS:
        return PeerResume.RESUME
    return PeerResume.LATCHED


def resume(
    sample: RigSample, peer: PeerValues, params: CoreParams, state: CoreState
) -> tuple[CoreState, frozenset[Trip]]:
    """Resume after the peer's return: the state with the trips whose cause is gone cleared (bumpless
    restart, :func:`telethermo.control.core.clear_faults`) and the set of trips cleared."""
    new = clear_faults(sample, peer, params, state)
    return new, frozenset(state.env.trips) - frozenset(new.env.trips)
