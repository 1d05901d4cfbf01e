"""Every heartbeat and boot-up on the bus (CiA 301 §7.2.8.3.2.2): which nodes are alive,
in which NMT state."""

from __future__ import annotations

import threading
from typing import Callable

import can
import canopen

from telethermo.device.netconfig import NetworkConfig
from telethermo.cia301 import NMT_UNKNOWN, nmt_state_name


class HeartbeatWatch(can.Listener):
    """Every heartbeat / boot-up on the bus: node-ID -> (last state byte, time, count, boot-ups), every state
    each node reported (``states``: a state held for 2 ms between two heartbeats is still seen), and every
    NMT command of another NMT master (``nmt``: (time, command specifier, node-ID); a client does not hear
    its own frames)."""

    def __init__(self) -> None:
        self.cond = threading.Condition()
        self.last: dict[int, tuple[int, float]] = {}
        self.boot_ups: dict[int, int] = {}
        self.count: dict[int, int] = {}
        self.states: dict[int, list[tuple[int, float]]] = {}
        self.nmt: list[tuple[float, int, int]] = []

    def on_message_received(self, msg: can.Message) -> None:
        cob = msg.arbitration_id
        if msg.is_extended_id or msg.is_remote_frame:
            return
        if cob == 0x000 and len(msg.data) == 2:
            with self.cond:
                self.nmt.append((msg.timestamp, msg.data[0], msg.data[1]))
                self.cond.notify_all()
            return
        if not 0x701 <= cob <= 0x77F or len(msg.data) != 1:
            return
        n = cob - 0x700
        with self.cond:
            self.last[n] = (msg.data[0] & 0x7F, msg.timestamp)
            self.states.setdefault(n, []).append((msg.data[0] & 0x7F, msg.timestamp))
            self.count[n] = self.count.get(n, 0) + 1
            if msg.data[0] == 0:
                self.boot_ups[n] = self.boot_ups.get(n, 0) + 1
            self.cond.notify_all()

    def wait_for(self, pred: Callable[[], bool], timeout_s: float) -> bool:
        with self.cond:
            return self.cond.wait_for(pred, timeout_s)

    def state_name(self, node_id: int) -> str:
        with self.cond:
            s = self.last.get(node_id)
        return nmt_state_name(s[0]) if s else NMT_UNKNOWN


def watch_heartbeats(nw: canopen.Network) -> HeartbeatWatch:
    """A watch listening on ``nw``'s notifier from now on."""
    w = HeartbeatWatch()
    nw.notifier.add_listener(w)
    return w


def heartbeat_wait_s(net: NetworkConfig) -> float:
    """How long to listen to be sure to hear every live node's heartbeat once, s."""
    return max(0.05, 2.5 * net.heartbeat.producer_ms / 1000.0)
