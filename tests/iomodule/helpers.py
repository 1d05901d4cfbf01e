"""The I/O module tests' own view of the bus: a canopen client of the module (a RemoteNode from
bus_config/io_module.eds), EMCY and heartbeat frames recorded."""

from __future__ import annotations

import time

import can
import canopen

from telethermo.bus_config import path

MODULE_ID, CONTROLLER_ID = 3, 1
EDS = str(path("io_module.eds"))


class Bus:
    """The test's own view of the bus: a canopen network with the module as a RemoteNode, and the EMCY and
    heartbeat frames of every node with their arrival time (time.monotonic, the clock the test kills by) and
    the hub's time stamp of the frame (time.time when the hub took it from its sender: the wire's clock)."""

    def __init__(self, port: int):
        self.network = canopen.Network(
            can.Bus(interface="socketcand", host="127.0.0.1", port=port, channel="vcan0", tcp_tune=True)
        )
        self.network.connect()
        self.node = self.network.add_node(MODULE_ID, EDS)
        self.node.sdo.RESPONSE_TIMEOUT = 1.0
        self.emcys: list[tuple[float, int, bytes, float]] = []
        self.heartbeats: list[tuple[float, int, int, float]] = []
        self.network.subscribe(0x80 + MODULE_ID, self._on_emcy)
        for node_id in (MODULE_ID, CONTROLLER_ID):
            self.network.subscribe(0x700 + node_id, self._on_heartbeat)

    def _on_emcy(self, cob, data, ts):
        self.emcys.append((time.monotonic(), int.from_bytes(data[:2], "little"), bytes(data[3:]), ts))

    def _on_heartbeat(self, cob, data, ts):
        self.heartbeats.append((time.monotonic(), cob - 0x700, data[0], ts))

    def wait(self, what, timeout_s: float = 10.0, every_s: float = 0.005):
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            got = what()
            if got:
                return got
            time.sleep(every_s)
        raise AssertionError(f"timed out waiting for {what}")

    def sdo_settled(self, attempts: int = 20) -> None:
        """Make the test's next SDO reads its own: the driver's client shares the module's one SDO channel
        (CiA 301: one client per server channel at a time), and under load a duplicate answer to a request
        it retried after its timeout may still be on its way when its commissioning returns. The module
        answers in order, so 0x1000 is read until the answer is this read's; a stray (canopen: "returned a
        value for ... instead") is dropped, and the answer of the read it spoilt with it."""
        for _ in range(attempts):
            try:
                if self.node.sdo.upload(0x1000, 0):
                    return
            except canopen.SdoCommunicationError as exc:
                if "instead" not in str(exc):
                    raise
                time.sleep(0.2)  # the spoilt read's own answer arrives meanwhile; the next request drops it
        raise AssertionError(f"the module's SDO channel did not settle in {attempts} reads")

    def module_state(self) -> int | None:
        states = [s for _, n, s, _ in self.heartbeats if n == MODULE_ID]
        return states[-1] if states else None

    def close(self):
        self.network.disconnect()


def up(bus: Bus) -> bool:
    try:
        return bus.node.sdo[0x1000].raw == 0x000C0191
    except (canopen.SdoCommunicationError, canopen.SdoAbortedError):
        return False
