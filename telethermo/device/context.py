"""What the CiA 301 services of one device share: NMT state, lock, counters, timer thread, sending.

:class:`DeviceCore` is handed to every service module (:mod:`.nmt`, :mod:`.sdo_gate`,
:mod:`.pdo_engine`, :mod:`.sync_consumer`, :mod:`.heartbeat`, :mod:`.emcy_producer`,
:mod:`.od_access`); the thin :class:`telethermo.device.device.Device` composes them, hands
each the few services it calls (the heartbeat consumer and the PDO length check raise EMCYs, the SYNC
consumer runs the PDOs) and wires the NMT transitions and the SDO write side effects.
"""

from __future__ import annotations

import logging
import threading
from dataclasses import dataclass
from enum import IntEnum
from typing import Any, Callable

import can
import canopen

from telethermo.device.scheduler import Scheduler

logger = logging.getLogger("telethermo.device.device")

#: ``callback(can_id, data, timestamp_s)`` for a subscribed COB-ID (canopen.Network.subscribe: a bytearray)
FrameCallback = Callable[[int, bytearray, float], None]


class NmtState(IntEnum):
    """NMT states with their heartbeat codes."""

    INITIALISING = 0
    STOPPED = 4
    OPERATIONAL = 5
    PRE_OPERATIONAL = 127


class NmtCommand(IntEnum):
    """NMT command specifiers (first byte of a COB-ID 0 frame)."""

    START = 0x01
    STOP = 0x02
    ENTER_PRE_OPERATIONAL = 0x80
    RESET_NODE = 0x81
    RESET_COMMUNICATION = 0x82


#: states in which the device serves SDO and sends EMCY
SERVING = (NmtState.PRE_OPERATIONAL, NmtState.OPERATIONAL)


@dataclass(slots=True)
class DeviceStats:
    """Counters of the device layer (the first six are also in the OD at 0x2710..0x2715)."""

    malformed_frames: int = 0
    unknown_cobid_frames: int = 0
    callback_errors: int = 0
    sync_count: int = 0
    rpdo_count: int = 0
    peer_losses: int = 0
    rpdo_ignored: int = 0
    tpdo_sent: int = 0
    emcy_sent: int = 0
    emcy_suppressed: int = 0
    send_errors: int = 0


class DeviceCore:
    """The shared state of one device's services.

    Attributes:
        network, node_id, node: the canopen network, this node's ID, its LocalNode.
        store: the LocalNode's data store (index -> sub-index -> raw bytes).
        clock: monotonic clock (s) of every deadline.
        lock: the device lock (re-entrant): SYNC processing, RPDO commits, SDO writes, NMT transitions.
        scheduler: the device's timer thread (heartbeat, consumer timeouts, EMCY inhibit, event timers).
        state: the NMT state; ``running`` between ``start()`` and ``close()``.
        extended: the frame being dispatched has a 29-bit ID (set by the frame watch; the service
            handlers ignore such a frame: canopen dispatches by the bare identifier).
    """

    def __init__(
        self,
        network: canopen.Network,
        node_id: int,
        node: canopen.LocalNode,
        *,
        clock: Callable[[], float],
        stats: DeviceStats,
    ):
        self.network = network
        self.node_id = node_id
        self.node = node
        self.store: dict[int, dict[int, bytes]] = node.data_store
        self.clock = clock
        self.stats = stats
        self.lock = threading.RLock()
        self.scheduler = Scheduler(f"canopen-dev-{node_id}", clock)
        self.state = NmtState.INITIALISING
        self.running = False
        self.extended = False

    def u(self, index: int, sub: int) -> int:
        """An unsigned object's value from the store."""
        return int.from_bytes(self.store[index][sub], "little")

    def send(self, cob_id: int, data: bytes) -> None:
        """Send one frame; a failed send is counted and logged, never raised."""
        try:
            self.network.send_message(cob_id, data)
        except (can.CanError, RuntimeError, OSError) as exc:
            self.stats.send_errors += 1
            logger.warning("node %d: send 0x%03X failed: %s", self.node_id, cob_id, exc)

    def subscribe(self, cob_id: int, callback: FrameCallback) -> tuple[int, FrameCallback]:
        self.network.subscribe(cob_id, callback)
        return cob_id, callback

    def unsubscribe(self, cob_id: int, callback: FrameCallback) -> None:
        """Unsubscribe; a subscription already gone is no error."""
        try:
            self.network.unsubscribe(cob_id, callback)
        except (KeyError, ValueError):
            pass

    def call(self, fns: list[Callable[..., None]], *args: Any) -> None:
        """Call every listener; one that raises is counted and logged (never kills the receive thread)."""
        for fn in fns:
            try:
                fn(*args)
            except Exception:  # a callback must never kill the receive thread
                self.callback_failed(fn)

    def callback_failed(self, fn: Callable[..., Any]) -> None:
        """Count a failed callback; log the first 5 with their traceback, then every 1000th."""
        self.stats.callback_errors += 1
        n = self.stats.callback_errors
        if n <= 5 or n % 1000 == 0:
            logger.exception("node %d: callback %r failed (%d so far)", self.node_id, fn, n)
