"""Real CANopen nodes for the monitor's tests: canopen LocalNodes built from bus_config's EDS files
(the servers), canopen RemoteNodes (the clients) and a sniffer, all on one python-can virtual bus."""

from __future__ import annotations

import itertools
import time
from pathlib import Path

import can
import canopen
import pytest
from canopen.objectdictionary import import_od

from telethermo import bus_config
from telethermo.monitor.records import MonitorConfig, NodeInfo
from telethermo.nodes.launch import wait_for

EDS_DIR = Path(bus_config.__file__).resolve().parent
MASTER_EDS, SLAVE_EDS = EDS_DIR / "master.eds", EDS_DIR / "slave.eds"
_channels = itertools.count()


def monitor_config(**kw) -> MonitorConfig:
    """Monitor settings knowing both nodes by their real EDS."""
    return MonitorConfig(
        nodes={
            1: NodeInfo("master", import_od(str(MASTER_EDS), 1)),
            2: NodeInfo("slave", import_od(str(SLAVE_EDS), 2)),
        },
        **kw,
    )


class Collector(can.Listener):
    def __init__(self) -> None:
        self.messages: list[can.Message] = []

    def on_message_received(self, msg: can.Message) -> None:
        self.messages.append(msg)


class CanopenBench:
    """Servers (LocalNode 1 master, 2 slave), clients (RemoteNode 1, 2) and a sniffer on one bus."""

    def __init__(self, extra_listeners=()) -> None:
        ch = f"tt-monitor-test-{next(_channels)}-{time.monotonic_ns()}"
        self.sniffer_bus = can.Bus(interface="virtual", channel=ch)
        self.collector = Collector()
        self.sniffer = can.Notifier(self.sniffer_bus, [self.collector, *extra_listeners], timeout=0.05)
        self.server = canopen.Network()
        self.client = canopen.Network()
        for nw in (self.server, self.client):
            nw.NOTIFIER_CYCLE = 0.05  # quick shutdown
            nw.connect(interface="virtual", channel=ch)
        self.master = canopen.LocalNode(1, str(MASTER_EDS))
        self.slave = canopen.LocalNode(2, str(SLAVE_EDS))
        self.server.add_node(self.master)
        self.server.add_node(self.slave)
        self.r_master = self.client.add_node(1, str(MASTER_EDS))
        self.r_slave = self.client.add_node(2, str(SLAVE_EDS))

    def wait_frames(self, n: int, timeout_s: float = 10.0) -> list[can.Message]:
        """Wait until the sniffer has ``n`` frames (the virtual bus is asynchronous)."""
        wait_for(lambda: len(self.collector.messages) >= n, timeout_s, poll_s=0.005)
        return list(self.collector.messages)

    def exchange(self, node: int, data: bytes, timeout_s: float = 10.0) -> can.Message:
        """Send one SDO request to ``node`` by hand and wait for the server's response on the bus.

        CiA 301 allows one outstanding request per SDO channel: a client sends the next request of a
        transfer only after the response to the previous one. Waiting for that response (not a fixed
        sleep) keeps a hand-driven client within the protocol however slowly the server thread runs.
        """
        resp_id = 0x580 + node
        seen = sum(1 for m in list(self.collector.messages) if m.arbitration_id == resp_id)
        self.client.send_message(0x600 + node, bytes(data))
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            resps = [m for m in list(self.collector.messages) if m.arbitration_id == resp_id]
            if len(resps) > seen:
                return resps[seen]
            time.sleep(0.002)
        raise AssertionError(f"no SDO response of node {node} within {timeout_s} s to {bytes(data).hex()}")

    def close(self) -> None:
        for node in (self.master, self.slave):
            node.nmt.stop_heartbeat()
        self.client.disconnect()
        self.server.disconnect()
        self.sniffer.stop()
        self.sniffer_bus.shutdown()


@pytest.fixture
def canbus():
    b = CanopenBench()
    try:
        yield b
    finally:
        b.close()
