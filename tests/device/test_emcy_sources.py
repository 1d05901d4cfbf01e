"""One EMCY code, several holders (issue 12, FAILs 2 and 6): the heartbeat consumer and the node
program's peer_lost trip both use 0x8130. 0x1001 and the EMCY frames must follow the errors still
present: a peer's returning heartbeat clears the consumer's error only, an unrelated watched node
does not clear it, and an entry removed from 0x1016 takes its heartbeat error with it.

The device runs live on a virtual bus; heartbeats are raw frames, 0x1001/0x1003 are read with
canopen's RemoteNode and the EMCY frames come from canopen's EMCY consumer (no project client code).
"""

from __future__ import annotations

import threading

from telethermo.device import DeviceSettings
from telethermo.nodes.launch import wait_for

HB_MS = 150


def _codes(node) -> list[int]:
    return [e.code for e in list(node.emcy.log)]


def _wait(pred, timeout: float = 10.0) -> bool:
    return wait_for(pred, timeout, poll_s=0.01)


class Beater:
    """A fake node's heartbeat (raw frames) every 30 ms while ``on`` is set."""

    def __init__(self, bus, node_id: int):
        self.bus, self.node_id = bus, node_id
        self.on = threading.Event()
        self._stop = threading.Event()
        self._t = threading.Thread(target=self._run, daemon=True)
        self._t.start()

    def _run(self):
        import can

        while not self._stop.wait(0.03):
            if self.on.is_set():
                self.bus.send(
                    can.Message(arbitration_id=0x700 + self.node_id, data=[5], is_extended_id=False)
                )

    def close(self):
        self._stop.set()
        self._t.join(1)


def _setup(lab):
    dev = lab.device("master", settings=DeviceSettings(heartbeat_consumers=((2, HB_MS), (5, HB_MS))))
    node = lab.client("master")
    node.sdo["Inhibit time EMCY"].raw = 0
    peer, other = Beater(lab.raw_bus(), 2), Beater(lab.raw_bus(), 5)
    lab._stack.callback(peer.close)
    lab._stack.callback(other.close)
    return dev, node, peer, other


def _lose(dev, beater, node_id):
    beater.on.clear()
    assert _wait(lambda: dev.peer_status(node_id) == "lost")


def _seen(dev, beater, node_id):
    beater.on.set()
    assert _wait(lambda: dev.peer_status(node_id) == "alive")


def test_a_returning_heartbeat_leaves_the_trip_it_shares_0x8130_with(lab):
    dev, node, peer, other = _setup(lab)
    _seen(dev, peer, 2)
    _lose(dev, peer, 2)
    dev.raise_emcy(0x8130)  # the node program's peer_lost trip (nodes/runtime.py)
    assert _wait(lambda: 0x8130 in _codes(node))
    _seen(dev, peer, 2)  # the heartbeat is back, the trip still latched
    # the SDO round trip orders the frames: an EMCY the heartbeat's handling sent is in the log by its answer
    assert node.sdo["Error register"].raw == 0x11
    assert 0x0000 not in _codes(node)
    assert _codes(node) == [0x8130]  # one loss, one EMCY 0x8130 (not one per holder)
    dev.clear_emcy(0x8130)  # the trip is cleared: now the error is gone
    assert _wait(lambda: 0x0000 in _codes(node))
    assert node.sdo["Error register"].raw == 0
    assert node.sdo[0x1003][0].raw == 1  # one occurrence in the history


def test_an_unrelated_watched_node_returning_does_not_clear_the_peers_error(lab):
    dev, node, peer, other = _setup(lab)
    _seen(dev, peer, 2)
    _seen(dev, other, 5)
    _lose(dev, other, 5)
    _lose(dev, peer, 2)
    _seen(dev, other, 5)  # node 5 is back, node 2 still silent
    assert node.sdo["Error register"].raw == 0x11  # (the round trip orders the frames, as above)
    assert 0x0000 not in _codes(node)
    _seen(dev, peer, 2)
    assert _wait(lambda: 0x0000 in _codes(node))
    assert node.sdo["Error register"].raw == 0


def test_removing_the_0x1016_entry_of_a_lost_node_removes_its_heartbeat_error(lab):
    dev, node, peer, other = _setup(lab)
    _seen(dev, peer, 2)
    _seen(dev, other, 5)
    _lose(dev, peer, 2)
    assert node.sdo["Error register"].raw == 0x11
    node.sdo["Consumer heartbeat time"][2].raw = (5 << 16) | (
        HB_MS + 50
    )  # another entry changed: node 2 still lost
    assert dev.peer_status(2) == "lost" and node.sdo["Error register"].raw == 0x11
    assert 0x0000 not in _codes(node)
    node.sdo["Consumer heartbeat time"][1].raw = 0  # node 2 no longer watched
    assert _wait(lambda: 0x0000 in _codes(node))
    assert node.sdo["Error register"].raw == 0
    assert 2 not in dev.heartbeat.consumers


def test_an_unchanged_entry_keeps_watching_an_alive_node(lab):
    dev, node, peer, other = _setup(lab)
    _seen(dev, peer, 2)
    node.sdo["Consumer heartbeat time"][2].raw = 0  # only the spare entry changes
    assert dev.peer_status(2) == "alive"
    _lose(dev, peer, 2)  # its deadline still runs: the loss is detected
    assert _wait(lambda: 0x8130 in _codes(node))


def test_one_emcy_per_lost_node_while_the_peer_trip_holds_0x8130(lab):
    """Issue 25: the program's peer_lost trip (subject: its peer, node 2) holds 0x8130; node 5, also
    watched, is lost: the consumer's EMCY 0x8130 naming node 5 goes out (a monitor learns node 5 is
    gone), and again at its second loss. Node 2's own loss stays one error with the trip."""
    dev, node, peer, other = _setup(lab)
    _seen(dev, peer, 2)
    _seen(dev, other, 5)
    dev.raise_emcy(0x8130, data=b"\x02", subject=2)  # the peer trip (PDOs missing, heartbeat alive)
    assert _wait(lambda: _codes(node) == [0x8130])
    _lose(dev, other, 5)
    assert _wait(lambda: _codes(node) == [0x8130, 0x8130])
    assert list(node.emcy.log)[-1].data[0] == 5  # manufacturer byte 0: the lost node
    _seen(dev, other, 5)
    _lose(dev, other, 5)  # lost again: a new occurrence
    assert _wait(lambda: _codes(node) == [0x8130] * 3)
    _lose(dev, peer, 2)  # the trip's own peer: the same error, no frame
    with dev.core.lock:  # the timer's loss handling (status, then its EMCY, under this lock) is over
        pass
    assert node.sdo[0x1003][0].raw == 3 and node.sdo["Error register"].raw == 0x11  # and its frames are in
    assert _codes(node) == [0x8130] * 3
    _seen(dev, other, 5)
    _seen(dev, peer, 2)
    dev.clear_emcy(0x8130)
    assert _wait(lambda: _codes(node)[-1:] == [0x0000])
    assert node.sdo["Error register"].raw == 0
