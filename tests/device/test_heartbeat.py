"""Heartbeat producer (0x1017) and consumer (0x1016): period, timeout with EMCY 0x8130, the peer's
return, and the consumer configuration rules."""

from __future__ import annotations

import statistics
import threading
import time

import pytest
from canopen import SdoAbortedError

from telethermo.device import DeviceSettings
from telethermo.nodes.launch import wait_for
from tests.device.conftest import run_due_jobs


def heartbeats(lab, bus, cob_id: int, n: int, timeout: float = 5.0) -> list[float]:
    stamps = []
    end = time.monotonic() + timeout
    while len(stamps) < n and time.monotonic() < end:
        m = lab.recv_until(
            bus, lambda m: m.arbitration_id == cob_id and list(m.data) != [0], end - time.monotonic()
        )
        if m is not None:
            stamps.append(m.timestamp)
    return stamps


def wait_emcy(node, code: int, timeout: float = 10.0):
    """The first EMCY with ``code`` in canopen's EMCY consumer log (waiting up to ``timeout`` s)."""

    def first():
        return next((e for e in list(node.emcy.log) if e.code == code), None)

    wait_for(lambda: first() is not None, timeout, poll_s=0.01)
    return first()


def test_producer_period_follows_0x1017_and_0_stops_it(lab):
    dev = lab.device("master", settings=DeviceSettings(heartbeat_producer_ms=40))
    bus = lab.raw_bus()
    stamps = heartbeats(lab, bus, 0x701, 8)
    assert len(stamps) == 8
    median = statistics.median(b - a for a, b in zip(stamps, stamps[1:]))
    assert 0.020 < median < 0.080  # the configured 40 ms, with a loaded machine's slack
    node = lab.client("master")
    node.sdo["Producer heartbeat time"].raw = 0
    run_due_jobs(dev)  # a heartbeat the timer was sending as the write came is out: drain it
    while bus.recv(0) is not None:
        pass
    assert lab.recv_until(bus, lambda m: m.arbitration_id == 0x701, 0.3) is None
    node.sdo["Producer heartbeat time"].raw = 25
    assert len(heartbeats(lab, bus, 0x701, 3)) == 3


def test_consumer_detects_loss_raises_emcy_and_sees_the_peer_back(lab):
    master = lab.device(
        "master", settings=DeviceSettings(heartbeat_producer_ms=50, heartbeat_consumers=((2, 200),))
    )
    events, cond = [], threading.Condition()

    def on_peer(ev):
        with cond:
            events.append((ev.node_id, ev.kind))
            cond.notify_all()

    master.add_peer_listener(on_peer)
    watcher = lab.client("master")  # canopen's EMCY consumer for node 1
    slave = lab.device("slave", settings=DeviceSettings(heartbeat_producer_ms=50))

    def wait_for(kind):
        with cond:
            return cond.wait_for(lambda: (2, kind) in events, 3.0)

    assert wait_for("seen") and wait_for("bootup")
    assert master.peer_status(2) == "alive" and master.read("peer_alive") is True
    slave.close()  # the peer falls silent
    assert wait_for("lost")
    emcy = wait_emcy(watcher, 0x8130)
    assert emcy is not None and emcy.register & 0x11 == 0x11  # generic + communication bits
    assert master.peer_status(2) == "lost" and master.read("peer_alive") is False
    assert watcher.sdo["peer_losses"].raw == 1
    assert watcher.sdo["Error register"].raw & 0x10
    assert watcher.sdo[0x1003][1].raw & 0xFFFF == 0x8130
    lab.device("slave", settings=DeviceSettings(heartbeat_producer_ms=50))  # restarted peer
    assert wait_for("back")
    reset = wait_emcy(watcher, 0x0000)
    assert reset is not None and reset.register == 0
    assert master.peer_status(2) == "alive" and watcher.sdo["Error register"].raw == 0


def test_consumer_entries_with_the_same_node_twice_are_refused(lab):
    lab.device("master")
    node = lab.client("master")
    entries = node.sdo["Consumer heartbeat time"]
    assert entries[1].raw == (2 << 16) | 250 and entries[2].raw == 0
    entries[2].raw = (5 << 16) | 300  # a second peer: fine
    with pytest.raises(SdoAbortedError) as exc:
        entries[2].raw = (2 << 16) | 300  # node 2 is already watched by entry 1
    assert exc.value.code == 0x06040043
    assert entries[2].raw == (5 << 16) | 300
    with pytest.raises(SdoAbortedError) as exc:
        node.sdo.download(0x1016, 3, (6 << 16 | 300).to_bytes(4, "little"))
    assert exc.value.code == 0x06090011  # no such sub-index
