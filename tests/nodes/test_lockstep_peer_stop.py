"""The lockstep SYNC producer never waits for a peer that reports STOPPED (issue 12, the flaky
``test_record_kill.py::test_a_slave_stopped_for_more_than_a_counter_wrap...``: "the master stalled").

The race: a peer's heartbeat that reports STOPPED is told to the runtime as a "state" event only when the
heartbeat consumer saw it alive just before. Under load the consumer can time out around the NMT STOP (a
heartbeat 250 ms late): the peer is "lost", and its next heartbeat, already STOPPED, comes as "back", not
as "state". The runtime did not read the state of a "back" (nor of a first "seen") event, so the peer
counted as alive and not paused: every cycle owed a PDO that a stopped node never sends, and the producer
waited its patience bound (20 x half the consumer time, 2.5 s) on every cycle, about 400 times slower than
the SYNC period.

Here the race is forced, not waited for: the master runtime runs in this process on python-can's virtual
bus, and the peer is a raw python-can client that sends heartbeats (0x702) with the NMT state the test
chooses and never answers a SYNC (as a STOPPED node). The test makes the consumer see the peer OPERATIONAL,
then lost, then back STOPPED (or STOPPED at its first heartbeat), and then runs lockstep cycles: none may
time out waiting for the peer (the buggy producer timed out on every one).
"""

from __future__ import annotations

import threading
import uuid
from pathlib import Path

import can
import pytest

from telethermo.control.types import Mode, Role
from telethermo.device.device import NmtState
from telethermo.device.netconfig import load_network
from telethermo.nodes.launch import wait_for
from telethermo.nodes.options import NodeOptions
from telethermo.nodes.parts import build_parts
from telethermo.nodes.runtime import NodeRuntime
from telethermo.transport.bus import TransportSettings

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "sim" / "scenes" / "probe_touches_al_steel_wood.toml"
NET = load_network()
MASTER_ID = NET.node("master").node_id
SLAVE_ID = NET.node("slave").node_id
CYCLES = 5


class FakePeer:
    """The slave's place on the bus: heartbeats every 50 ms with ``state`` while ``beating``; no PDO ever."""

    def __init__(self, channel: str) -> None:
        self.bus = can.Bus(interface="virtual", channel=channel, receive_own_messages=False)
        self.state = int(NmtState.OPERATIONAL)
        self.beating = threading.Event()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="fake-peer-heartbeat", daemon=True)
        self._thread.start()

    def _loop(self) -> None:
        while not self._stop.wait(0.05):
            if self.beating.is_set():
                self.bus.send(
                    can.Message(arbitration_id=0x700 + SLAVE_ID, data=[self.state], is_extended_id=False)
                )

    def close(self) -> None:
        self._stop.set()
        self._thread.join(5)
        self.bus.shutdown()


@pytest.fixture
def pair():
    channel = f"peerstop-{uuid.uuid4().hex[:8]}"
    peer = FakePeer(channel)
    opts = NodeOptions(role=Role.MASTER, scene=SCENE, timing="lockstep", produce_sync=True)
    parts = build_parts(opts, period_s=NET.sync.period_s)
    rt = NodeRuntime(
        Role.MASTER,
        MASTER_ID,
        NET,
        TransportSettings("virtual", channel),
        parts,
        mode=Mode.TELEPRESENCE,
        lockstep=True,
        produce_sync=True,
        record_timing=False,
    )
    rt.start()
    yield rt, peer
    rt.stop("test end")
    peer.close()


def _run_cycles(rt: NodeRuntime) -> int:
    """CYCLES lockstep cycles in a thread; the producer is stopped after 60 s at most (the buggy one needs
    CYCLES x 2.5 s), so that a regression fails on the count of timeouts rather than hanging the suite."""
    done: list[int] = []
    t = threading.Thread(target=lambda: done.append(rt.run_producer(CYCLES)), daemon=True)
    t.start()
    t.join(60)
    rt.stop_event.set()
    t.join(10)
    return done[0] if done else -1


@pytest.mark.parametrize("path", ["lost_then_back_stopped", "first_seen_stopped"])
def test_the_producer_owes_nothing_to_a_peer_that_reports_stopped(pair, path):
    rt, peer = pair
    status = lambda: rt.device.peer_status(SLAVE_ID)  # noqa: E731
    if path == "lost_then_back_stopped":
        peer.beating.set()  # alive, OPERATIONAL
        assert wait_for(lambda: status() == "alive" and rt.device.peer_state(SLAVE_ID) == 5, 5)
        peer.beating.clear()  # a heartbeat late under load ...
        assert wait_for(lambda: status() == "lost", 5), "the consumer did not declare the peer lost"
        peer.state = int(NmtState.STOPPED)  # ... around the NMT STOP
    else:
        peer.state = int(NmtState.STOPPED)
    peer.beating.set()
    assert wait_for(
        lambda: status() == "alive" and rt.device.peer_state(SLAVE_ID) == int(NmtState.STOPPED), 5
    )

    assert _run_cycles(rt) == CYCLES
    assert rt.stats.lockstep_timeouts == 0, "the producer waited for PDOs of a STOPPED peer"
    assert rt.stats.cycles == CYCLES  # its own control cycles ran (its envelope reacts to the silence)
