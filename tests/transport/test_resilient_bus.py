"""The reconnecting bus (telethermo.transport.resilient) against the real hub, stopped and started again on
the same port, with python-can's socketcand client as the other party and canopen's Network on top."""

from __future__ import annotations

import threading
import time

import can
import canopen
import pytest

from telethermo.nodes.launch import wait_for
from telethermo.transport.bus import TransportSettings
from telethermo.transport.hub import HubConfig, HubThread
from telethermo.transport.resilient import ResilientBus, link_down_reason

pytestmark = pytest.mark.slow  # runs a hub


def _client(port: int) -> can.BusABC:
    return can.Bus(interface="socketcand", host="127.0.0.1", port=port, channel="telethermo", tcp_tune=True)


class Events:
    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.changes: list[tuple[bool, str]] = []
        self.frames: list[tuple[int, bytes]] = []

    def on_change(self, up: bool, reason: str) -> None:
        with self.lock:
            self.changes.append((up, reason))

    def on_frame(self, cob_id: int, data: bytes, timestamp: float) -> None:
        with self.lock:
            self.frames.append((cob_id, bytes(data)))


def _received(bus: can.BusABC, cob_id: int, timeout_s: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        msg = bus.recv(0.1)
        if msg is not None and msg.arbitration_id == cob_id:
            return True
    return False


def test_canopen_network_survives_the_hub_going_away_and_coming_back():
    ev = Events()
    hub = HubThread(HubConfig(idle_timeout_s=0)).__enter__()
    port = hub.port
    settings = TransportSettings("socketcand", "telethermo", host="127.0.0.1", port=port)
    bus = ResilientBus(settings, on_change=ev.on_change)
    net = canopen.Network(bus)
    net.connect()
    net.subscribe(0x181, ev.on_frame)
    other = _client(port)
    try:  # both are in raw mode: a frame held in the receiver's join grace is delivered after it
        other.send(can.Message(arbitration_id=0x181, data=b"\x01", is_extended_id=False))
        assert wait_for(lambda: (0x181, b"\x01") in ev.frames, 10)

        hub.__exit__(None, None, None)  # the hub ends: every client's TCP stream is closed
        other.shutdown()
        assert wait_for(lambda: ev.changes[:1] and ev.changes[0][0] is False, 10), "outage not noticed"
        for _ in range(5):  # sends while down: dropped, counted, never raised
            net.send_message(0x701, b"\x05")
        net.check()  # the notifier thread did not die
        assert bus.stats.frames_dropped >= 5 and not bus.is_up
        attempts = bus.stats.attempts
        assert wait_for(lambda: bus.stats.attempts >= attempts + 2, 10), "no retries while the hub is away"

        hub = HubThread(HubConfig(port=port, idle_timeout_s=0)).__enter__()  # back on the same port
        assert wait_for(lambda: len(ev.changes) >= 2, 10), "the bus did not come back by itself"
        assert ev.changes[1][0] is True and bus.is_up
        other = _client(port)
        other.send(can.Message(arbitration_id=0x181, data=b"\x02", is_extended_id=False))
        assert wait_for(lambda: (0x181, b"\x02") in ev.frames, 10), "no frames after the return"
        net.send_message(0x701, b"\x05")
        assert _received(other, 0x701), "our frames do not reach the other client after the return"
        net.check()
        assert bus.stats.outages == 1 and bus.stats.reopens == 1 and bus.stats.down_s > 0
    finally:
        other.shutdown()
        net.disconnect()
        hub.__exit__(None, None, None)


def test_a_socketcand_server_that_is_gone_is_reported_without_opening_the_bus():
    with HubThread(HubConfig(idle_timeout_s=0)) as hub:
        port = hub.port
        settings = TransportSettings("socketcand", "telethermo", host="127.0.0.1", port=port)
        assert link_down_reason(settings) is None
    assert "socketcand server 127.0.0.1" in link_down_reason(settings)


def test_socketcan_link_state_from_sysfs(tmp_path):
    settings = TransportSettings("socketcan", "can7")
    assert "does not exist" in link_down_reason(settings, tmp_path)
    d = tmp_path / "can7"
    d.mkdir()
    (d / "flags").write_text("0x80\n")  # IFF_NOARP, not IFF_UP
    (d / "operstate").write_text("down\n")
    assert "is down" in link_down_reason(settings, tmp_path)
    (d / "flags").write_text("0x81\n")  # up, carrier off (bus-off)
    assert "bus-off" in link_down_reason(settings, tmp_path)
    (d / "operstate").write_text("unknown\n")  # vcan when up
    assert link_down_reason(settings, tmp_path) is None
    assert link_down_reason(TransportSettings("virtual", "x")) is None
