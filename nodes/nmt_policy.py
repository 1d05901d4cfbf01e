"""The NMT-master policy of the pair, as pure decisions (state in, actions out): the node runtime
(:mod:`nodes.runtime`, the peer's heartbeat events and this node's NMT transitions) and the SYNC producer
(:mod:`nodes.producer`, its schedule) only carry out what these functions return.

The SYNC producer (the master by default) is the NMT master: it starts all nodes when the session starts,
starts again every peer that reports a boot-up or a pre-operational heartbeat (once per boot-up, once per
pre-operational report: first heartbeat, return, or another NMT master's command), and puts all nodes into
PRE-OPERATIONAL when the session ends, so that the peer does not take its silence for a loss. A peer that
another NMT master stopped or put into PRE-OPERATIONAL is *paused*: it answers no SYNC and owes no PDO. A
lost peer makes a SYNC consumer run its cycles locally (:mod:`nodes.fallback`).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from telethermo.control.types import Mode
from telethermo.device.context import NmtCommand, NmtState

_STOPPED, _OPERATIONAL, _PRE_OP = (
    int(NmtState.STOPPED),
    int(NmtState.OPERATIONAL),
    int(NmtState.PRE_OPERATIONAL),
)


@dataclass(frozen=True)
class PeerActions:
    """What a heartbeat event of the peer asks the node to do.

    Attributes:
        heartbeat_ok: tell the peer link the heartbeat is seen (True) or timed out (False).
        start_fallback: (SYNC consumer) run local cycles: the producer may be gone with the peer.
        boot: count a boot-up of the peer (its PDO debt and pause are void).
        paused: the peer's new pause (None: unchanged); a change is counted.
        nmt_start: (NMT master) send NMT START to the peer.
    """

    heartbeat_ok: bool
    start_fallback: bool = False
    boot: bool = False
    paused: bool | None = None
    nmt_start: bool = False


def on_peer_event(
    kind: str, state: int | None, *, nmt_master: bool, stopping: bool, paused: bool
) -> PeerActions:
    """The actions for a heartbeat-consumer event of the peer (``kind`` "seen", "lost", "back", "bootup",
    "state"; ``state`` its NMT state code, None when lost), given whether this node is the NMT master (the
    SYNC producer), is stopping, and holds the peer paused."""
    if kind == "lost":
        return PeerActions(heartbeat_ok=False, start_fallback=not nmt_master)
    boot = kind == "bootup"
    if boot:
        paused = False
    # the state a heartbeat reports after a loss is news too: a heartbeat late around an NMT STOP turns the
    # STOPPED report into a "back", not a "state" (the lockstep producer then waited for PDOs the stopped
    # peer never sends, 2.5 s per cycle); a first heartbeat may report STOPPED as well
    new_pause = None
    if kind in ("state", "back") or (kind == "seen" and state == _STOPPED):
        new_pause = peer_pause(state, paused)
    start = nmt_master and not stopping and (boot or state == _PRE_OP)
    return PeerActions(heartbeat_ok=True, boot=boot, paused=new_pause, nmt_start=start)


def peer_pause(state: int | None, paused: bool) -> bool | None:
    """The peer's pause after its heartbeat reports ``state``, None when unchanged: only a change from or to
    OPERATIONAL counts (before its first start a peer owes its PDOs from the start on); a boot-up (state 0,
    also as "back" after a loss) is the "bootup" event's."""
    if not state:
        return None
    now = state != _OPERATIONAL
    return now if now != paused else None


def peer_is_paused(paused: bool, peer_state: int | None) -> bool:
    """The peer answers no SYNC: it left OPERATIONAL (its heartbeat said so: ``paused``), or its last
    heartbeat reports STOPPED, whatever event brought that heartbeat (a stopped node never owes a PDO)."""
    return paused or peer_state == _STOPPED


def peer_schedule_status(heartbeat: str, *, unreachable: bool, paused: bool, peer_state: int | None) -> str:
    """The peer as the SYNC producer's schedule sees it before a SYNC: "alive", "lost", "unknown" (never seen)
    or "paused" (:func:`peer_is_paused`). ``heartbeat``: the heartbeat consumer's status; ``unreachable``:
    no bus, or back before the peer's."""
    if peer_is_paused(paused, peer_state):
        return "paused"
    return "lost" if unreachable else heartbeat


class LockstepWait(enum.Enum):
    """What the lockstep producer waits for after a SYNC."""

    PEER_PDOS = "the peer's PDOs of this cycle"
    NOTHING = "alone on the bus: nobody to wait for"
    PERIOD = "one SYNC period: the envelope keeps running"


def lockstep_wait(status: str, mode: Mode) -> LockstepWait:
    """After a lockstep SYNC: a live peer's PDOs; nothing when alone on the bus (rendering, identification:
    the peer never seen); else (peer lost, not yet seen in telepresence, or paused) one period."""
    if status == "alive":
        return LockstepWait.PEER_PDOS
    if status == "unknown" and mode is not Mode.TELEPRESENCE:
        return LockstepWait.NOTHING
    return LockstepWait.PERIOD


#: NMT commands of the NMT master to all nodes (node-ID 0): when the session starts and when it ends
SESSION_START = NmtCommand.START
SESSION_END = NmtCommand.ENTER_PRE_OPERATIONAL


def session_end_command(own: NmtState) -> NmtCommand | None:
    """At the session's end every node leaves OPERATIONAL (no PDOs, current 0) before the producer goes
    silent; nothing when this node is not OPERATIONAL (another NMT master's command holds)."""
    return SESSION_END if own is NmtState.OPERATIONAL else None


def sync_while_not_operational(own: NmtState) -> bool:
    """CiA 301: the SYNC producer produces in PRE-OPERATIONAL (paced by the period), not in STOPPED."""
    return own is NmtState.PRE_OPERATIONAL


@dataclass(frozen=True)
class OwnNmtActions:
    """What this node's NMT transition asks: cut the current (no control outside OPERATIONAL), count a
    departure from OPERATIONAL (its PDOs were dropped), power on again (reset node: the program's values)."""

    cut_current: bool
    left_operational: bool
    power_on: bool


def on_own_nmt(old: NmtState, new: NmtState, command: int | None) -> OwnNmtActions:
    """The actions for this node's NMT transition ``old`` -> ``new`` (``command``: the NMT command,
    if one)."""
    return OwnNmtActions(
        cut_current=new is not NmtState.OPERATIONAL,
        left_operational=old is NmtState.OPERATIONAL and new is not NmtState.OPERATIONAL,
        power_on=command == NmtCommand.RESET_NODE and new is NmtState.INITIALISING,
    )
