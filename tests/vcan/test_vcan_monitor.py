"""The monitor on a real SocketCAN interface: it says where the controller state comes from (SocketCAN
gives it only through error frames), decodes frames from another socket, and reads an error frame
(linux/can/error.h layout, sent through the kernel with CAN_ERR_FLAG) as the controller's state and
error counters."""

from __future__ import annotations

import can

from telethermo.monitor.run import bus_state_poller
from telethermo.monitor.state import Monitor


def test_monitor_on_socketcan_controller_state_from_error_frames(vcan_channel):
    rx = can.Bus(interface="socketcan", channel=vcan_channel)
    tx = can.Bus(interface="socketcan", channel=vcan_channel)
    try:
        mon = Monitor()
        poll = bus_state_poller(rx)
        poll(mon)
        assert mon.controller.state is None and mon.controller.source == "SocketCAN: only from error frames"
        tx.send(can.Message(arbitration_id=0x701, data=[0x05], is_extended_id=False))
        # CAN_ERR_CRTL | CAN_ERR_CNT; data[1] CAN_ERR_CRTL_TX_PASSIVE; TX/RX error counters 140 / 12
        tx.send(
            can.Message(arbitration_id=0x204, is_error_frame=True, data=bytes([0, 0x20, 0, 0, 0, 0, 140, 12]))
        )
        got = [rx.recv(5.0), rx.recv(5.0)]
        assert all(m is not None for m in got), got
        for m in got:
            mon.feed(m)
        assert mon.nodes[1].nmt_state == "OPERATIONAL"
        assert mon.stats.error_frames == 1
        assert (
            mon.controller.text()
            == "controller: ERROR-PASSIVE (from error frame)  TX errors 140  RX errors 12"
        )
        poll(mon)  # the poller keeps what an error frame said
        assert mon.controller.state == "ERROR-PASSIVE"
    finally:
        tx.shutdown()
        rx.shutdown()
