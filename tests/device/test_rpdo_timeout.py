"""RPDO timeout (issue 25): the RPDO event timer 0x1400+n sub 5 (ms) monitors the channel as CANopenNode
does: from the first RPDO received in OPERATIONAL, a late RPDO raises EMCY 0x8250 (byte 0: the RPDO
number) once, the next RPDO clears it; beside the node program's own peer trip (EMCY 0x8130), which it
leaves alone. The device runs live; RPDO frames are raw python-can frames, EMCYs and 0x1001/0x1003 come
from canopen's RemoteNode and EMCY consumer."""

from __future__ import annotations

import struct

import can

from telethermo.device import NmtCommand
from telethermo.nodes.launch import wait_for

from tests.device.conftest import ManualClock

RPDO1 = 0x182  # the master's RPDO1: the slave's TPDO1 (8 bytes, type 1)


def _wait(pred, timeout: float = 10.0) -> bool:
    return wait_for(pred, timeout, poll_s=0.01)


def _codes(node) -> list[int]:
    return [e.code for e in list(node.emcy.log)]


def _setup(lab, timer_ms: int, clock: ManualClock | None = None):
    dev = lab.device("master", clock=clock)
    node = lab.client("master")
    node.sdo["Inhibit time EMCY"].raw = 0
    node.sdo[0x1400][5].raw = timer_ms
    dev.nmt_command(NmtCommand.START, 1)
    bus = lab.raw_bus()
    return dev, node, bus


def _rpdo(bus) -> None:
    bus.send(can.Message(arbitration_id=RPDO1, data=struct.pack("<ff", 30.0, 0.5), is_extended_id=False))


def _rpdo_taken(dev, bus) -> None:
    """An RPDO, and back once the device has taken it (its deadline counts from the clock's time now)."""
    n = dev.rpdo_count(1)
    _rpdo(bus)
    assert dev.wait_rpdo(1, after=n, timeout=10.0)


def _no_new_emcy(node, codes: list[int]) -> None:
    """The EMCYs seen are ``codes``: an SDO round trip first, so that an EMCY the device sent before its
    answer has reached canopen's EMCY consumer (the client handles frames in order)."""
    node.sdo["Error register"].raw
    assert _codes(node) == codes


def test_a_late_rpdo_raises_0x8250_once_and_the_next_one_clears_it(lab):
    clock = ManualClock()
    dev, node, bus = _setup(lab, 150, clock)
    clock.advance(0.4, dev)  # no RPDO yet: not monitored, no error
    _no_new_emcy(node, [])
    assert node.sdo["Error register"].raw == 0
    _rpdo_taken(dev, bus)
    clock.advance(0.149, dev)  # silent for 149 ms: within the 150 ms
    _no_new_emcy(node, [])
    clock.advance(0.002, dev)  # silent for longer than 150 ms
    assert _wait(lambda: 0x8250 in _codes(node))
    emcy = list(node.emcy.log)[-1]
    assert emcy.code == 0x8250 and emcy.data[0] == 1 and emcy.register == 0x11
    assert node.sdo[0x1003][1].raw & 0xFFFF == 0x8250
    clock.advance(0.4, dev)
    _no_new_emcy(node, [0x8250])  # once, not once per event time
    _rpdo(bus)
    assert _wait(lambda: _codes(node) == [0x8250, 0x0000])
    assert node.sdo["Error register"].raw == 0
    clock.advance(0.151, dev)
    assert _wait(lambda: _codes(node)[-1] == 0x8250)  # monitored again from that RPDO


def test_rpdos_in_time_raise_nothing_and_timer_0_is_off(lab):
    clock = ManualClock()
    dev, node, bus = _setup(lab, 0, clock)
    _rpdo_taken(dev, bus)
    clock.advance(0.3, dev)
    _no_new_emcy(node, [])
    node.sdo[0x1400][5].raw = 1000
    _rpdo_taken(dev, bus)
    for _ in range(5):  # one every 900 ms: each within the 1000 ms of the one before
        clock.advance(0.9, dev)
        _rpdo_taken(dev, bus)
    clock.advance(0.9, dev)
    _no_new_emcy(node, [])
    assert node.sdo["Error register"].raw == 0


def test_the_rpdo_timeout_and_the_programs_peer_trip_keep_their_own_errors(lab):
    dev, node, bus = _setup(lab, 1000)
    dev.raise_emcy(0x8130, data=b"\x02", subject=2)  # the node program's peer_lost trip
    _rpdo(bus)
    assert _wait(lambda: _codes(node) == [0x8130, 0x8250])
    _rpdo(bus)  # RPDO back: the RPDO timeout alone clears
    assert _wait(lambda: dev.active_errors == (0x8130,))
    assert node.sdo["Error register"].raw == 0x11 and 0x0000 not in _codes(node)
    node.sdo[0x1400][5].raw = 0  # no longer monitored
    dev.clear_emcy(0x8130)  # the trip cleared: now no error is left
    assert _wait(lambda: _codes(node) == [0x8130, 0x8250, 0x0000])
    assert node.sdo["Error register"].raw == 0


def test_switching_the_timer_off_takes_its_error_with_it(lab):
    dev, node, bus = _setup(lab, 150)
    _rpdo(bus)
    assert _wait(lambda: _codes(node) == [0x8250])
    node.sdo[0x1400][5].raw = 0
    assert _wait(lambda: _codes(node) == [0x8250, 0x0000])
    assert node.sdo["Error register"].raw == 0


def test_leaving_operational_stops_the_monitoring(lab):
    clock = ManualClock()
    dev, node, bus = _setup(lab, 150, clock)
    _rpdo_taken(dev, bus)
    dev.nmt_command(NmtCommand.ENTER_PRE_OPERATIONAL, 1)
    clock.advance(0.4, dev)
    _no_new_emcy(node, [])
