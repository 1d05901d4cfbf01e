"""The NMT-master policy (nodes/nmt_policy.py) as a table: heartbeat events of the peer, this node's NMT
transitions and the SYNC producer's schedule, state in -> actions out (no bus: the runtime and the producer
only carry these out; tests/nodes/test_node_inprocess.py, test_nmt_from_outside.py and
test_lockstep_peer_stop.py run them on a bus)."""

from __future__ import annotations

import pytest
from hypothesis import given, strategies as st

from telethermo.control.types import Mode
from telethermo.device.context import NmtCommand, NmtState
from telethermo.nodes.nmt_policy import (
    LockstepWait,
    PeerActions,
    lockstep_wait,
    on_own_nmt,
    on_peer_event,
    peer_schedule_status,
    session_end_command,
    sync_while_not_operational,
)

BOOT, STOP, OP, PRE = 0, 4, 5, 127
KINDS = ("seen", "lost", "back", "bootup", "state")

# (kind, state, nmt_master, paused) -> actions (not stopping)
TABLE = [
    # a lost peer: the link hears no heartbeat; a SYNC consumer runs its cycles locally, the master does not
    (("lost", None, True, False), PeerActions(heartbeat_ok=False)),
    (("lost", None, False, True), PeerActions(heartbeat_ok=False, start_fallback=True)),
    # a boot-up: counted, the pause void; the NMT master starts it, a consumer does not
    (("bootup", BOOT, True, True), PeerActions(True, boot=True, nmt_start=True)),
    (("bootup", BOOT, False, False), PeerActions(True, boot=True)),
    # first heartbeat: pre-operational is started; operational needs nothing; STOPPED is a pause at once
    (("seen", PRE, True, False), PeerActions(True, nmt_start=True)),
    (("seen", OP, True, False), PeerActions(True)),
    (("seen", STOP, True, False), PeerActions(True, paused=True)),
    (("seen", STOP, True, True), PeerActions(True)),
    # another NMT master's command: a pause (and a restart, when pre-operational), then its end
    (("state", PRE, True, False), PeerActions(True, paused=True, nmt_start=True)),
    (("state", STOP, True, False), PeerActions(True, paused=True)),
    (("state", OP, True, True), PeerActions(True, paused=False)),
    (("state", OP, True, False), PeerActions(True)),
    (("state", PRE, False, False), PeerActions(True, paused=True)),
    # back after a loss: its reported state is news (a STOPPED report late around an NMT STOP)
    (("back", STOP, True, False), PeerActions(True, paused=True)),
    (("back", PRE, True, False), PeerActions(True, paused=True, nmt_start=True)),
    (("back", OP, True, True), PeerActions(True, paused=False)),
    (("back", BOOT, True, True), PeerActions(True)),  # a boot-up after a loss: the bootup event's
]


@pytest.mark.parametrize(
    "event, actions", TABLE, ids=[f"{e[0]}-{e[1]}-m{int(e[2])}-p{int(e[3])}" for e, _ in TABLE]
)
def test_peer_event_table(event, actions):
    kind, state, master, paused = event
    assert on_peer_event(kind, state, nmt_master=master, stopping=False, paused=paused) == actions


@given(
    st.sampled_from(KINDS),
    st.sampled_from((BOOT, STOP, OP, PRE)),
    st.booleans(),
    st.booleans(),
    st.booleans(),
)
def test_peer_event_properties(kind, state, master, stopping, paused):
    act = on_peer_event(
        kind, None if kind == "lost" else state, nmt_master=master, stopping=stopping, paused=paused
    )
    assert act.heartbeat_ok is (kind != "lost")
    if act.nmt_start:  # only the NMT master, while it runs, starts a booted or pre-operational peer
        assert master and not stopping and (kind == "bootup" or state == PRE)
    assert act.start_fallback is (kind == "lost" and not master)
    assert act.paused is None or act.paused is not paused  # a change, or nothing
    if act.paused is not None:
        assert act.paused is (state != OP) and kind != "bootup"


@pytest.mark.parametrize(
    "heartbeat, unreachable, paused, peer_state, status",
    [
        ("alive", False, False, OP, "alive"),
        ("alive", True, False, OP, "lost"),  # our bus is gone, or back before the peer's
        ("unknown", False, False, None, "unknown"),
        ("lost", False, False, OP, "lost"),
        ("alive", False, True, PRE, "paused"),
        ("alive", False, False, STOP, "paused"),  # a STOPPED heartbeat, whatever event brought it
        ("alive", True, False, STOP, "paused"),
    ],
)
def test_schedule_status(heartbeat, unreachable, paused, peer_state, status):
    got = peer_schedule_status(heartbeat, unreachable=unreachable, paused=paused, peer_state=peer_state)
    assert got == status


@pytest.mark.parametrize(
    "status, mode, wait",
    [
        ("alive", Mode.TELEPRESENCE, LockstepWait.PEER_PDOS),
        ("alive", Mode.RENDER, LockstepWait.PEER_PDOS),
        ("unknown", Mode.RENDER, LockstepWait.NOTHING),
        ("unknown", Mode.IDENTIFY, LockstepWait.NOTHING),
        ("unknown", Mode.TELEPRESENCE, LockstepWait.PERIOD),
        ("lost", Mode.RENDER, LockstepWait.PERIOD),
        ("paused", Mode.TELEPRESENCE, LockstepWait.PERIOD),
    ],
)
def test_lockstep_wait(status, mode, wait):
    assert lockstep_wait(status, mode) is wait


def test_session_end_and_sync_outside_operational():
    assert session_end_command(NmtState.OPERATIONAL) is NmtCommand.ENTER_PRE_OPERATIONAL
    assert (
        session_end_command(NmtState.STOPPED) is None
        and session_end_command(NmtState.PRE_OPERATIONAL) is None
    )
    assert sync_while_not_operational(NmtState.PRE_OPERATIONAL)
    assert not sync_while_not_operational(NmtState.STOPPED)


@pytest.mark.parametrize(
    "old, new, command, cut, left, power_on",
    [
        (NmtState.PRE_OPERATIONAL, NmtState.OPERATIONAL, NmtCommand.START, False, False, False),
        (NmtState.OPERATIONAL, NmtState.STOPPED, NmtCommand.STOP, True, True, False),
        (NmtState.OPERATIONAL, NmtState.PRE_OPERATIONAL, None, True, True, False),
        (NmtState.STOPPED, NmtState.PRE_OPERATIONAL, NmtCommand.ENTER_PRE_OPERATIONAL, True, False, False),
        (NmtState.OPERATIONAL, NmtState.INITIALISING, NmtCommand.RESET_NODE, True, True, True),
        (NmtState.OPERATIONAL, NmtState.INITIALISING, NmtCommand.RESET_COMMUNICATION, True, True, False),
    ],
)
def test_own_nmt_transitions(old, new, command, cut, left, power_on):
    act = on_own_nmt(old, new, command)
    assert (act.cut_current, act.left_operational, act.power_on) == (cut, left, power_on)
