"""Fixtures for the device-layer tests: each test gets its own python-can ``virtual`` channel.

The device under test runs on one canopen.Network; the client side is a second canopen.Network
(RemoteNode, SDO client, NMT master, EMCY consumer: canopen's code, not ours) or a raw python-can
bus on the same channel.
"""

from __future__ import annotations

import contextlib
import threading
import time
import uuid
from typing import Callable

import can
import canopen
import pytest

from telethermo.bus_config import path
from telethermo.device import Device, DeviceSettings

NODE_IDS = {"master": 1, "slave": 2}


class Lab:
    """Devices and clients on one virtual channel; everything is closed at the end of the test."""

    def __init__(self, stack: contextlib.ExitStack):
        self.channel = f"tt-{uuid.uuid4().hex[:10]}"
        self._stack = stack

    def network(self) -> canopen.Network:
        net = canopen.Network()
        net.NOTIFIER_CYCLE = 0.05  # the notifier thread notices shutdown within 50 ms
        net.connect(interface="virtual", channel=self.channel)
        self._stack.callback(net.disconnect)
        return net

    def device(
        self,
        role: str = "master",
        *,
        start: bool = True,
        node_id: int | None = None,
        settings: DeviceSettings | None = None,
        clock: Callable[[], float] | None = None,
    ) -> Device:
        extra = {} if clock is None else {"clock": clock}
        dev = Device(
            self.network(), node_id or NODE_IDS[role], path(f"{role}.eds"), settings=settings, **extra
        )
        self._stack.callback(dev.close)
        if start:
            dev.start()
        return dev

    def client(self, role: str = "master", node_id: int | None = None) -> canopen.RemoteNode:
        net = self.network()
        return net.add_node(node_id or NODE_IDS[role], str(path(f"{role}.eds")))

    def raw_bus(self) -> can.BusABC:
        bus = can.Bus(interface="virtual", channel=self.channel)
        self._stack.callback(bus.shutdown)
        return bus

    @staticmethod
    def recv_until(bus: can.BusABC, predicate, timeout: float = 2.0) -> can.Message | None:
        """First frame on ``bus`` for which ``predicate(msg)`` holds, or None after ``timeout`` s."""
        end = time.monotonic() + timeout
        while (left := end - time.monotonic()) > 0:
            msg = bus.recv(left)
            if msg is not None and predicate(msg):
                return msg
        return None


class ManualClock:
    """A monotonic clock (s) that moves only when the test moves it: given to a device, its deadlines
    (RPDO timeout, heartbeat consumer, EMCY inhibit) fall due when the test says, so "nothing happens
    within X s" is a fact of the clock, not of a sleep on a loaded machine."""

    def __init__(self, t0_s: float = 1000.0):
        self.t_s = t0_s

    def __call__(self) -> float:
        return self.t_s

    def advance(self, dt_s: float, *devices: Device) -> None:
        """Move the clock by ``dt_s`` and return once each device's timer thread has run every job that
        fell due."""
        self.t_s += dt_s
        for dev in devices:
            run_due_jobs(dev)


def run_due_jobs(dev: Device) -> None:
    """Return once the device's timer thread has run every job due by its clock's time now, and finished
    the one it was running: two probe jobs in turn (the second runs only after the batch of the first)."""
    for _ in range(2):
        ran = threading.Event()
        dev.core.scheduler.set("test-probe", dev.core.clock(), ran.set)
        assert ran.wait(30.0), "the device's timer thread did not run its due jobs"


@pytest.fixture
def lab():
    with contextlib.ExitStack() as stack:
        yield Lab(stack)
