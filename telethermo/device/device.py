"""A CiA 301 device over canopen.LocalNode: the behaviour the library leaves out (DESIGN.md §4).

canopen 2.4's LocalNode gives an object dictionary, an SDO server and frame plumbing. :class:`Device`
composes one module per CiA 301 service on top of it, as canopen's own ``LocalNode`` composes
``nmt``, ``emcy``, ``sdo`` and ``pdo``:

- :mod:`.nmt`: NMT slave: INITIALISING → boot-up → PRE-OPERATIONAL on power-on, reset node and reset
  communication; start / stop / enter pre-operational; SDO only in PRE-OPERATIONAL and OPERATIONAL,
  PDOs only in OPERATIONAL. Reset node restores every object, reset communication 0x1000..0x1FFF,
  to the power-on values (EDS defaults overridden by :class:`DeviceSettings`).
- :mod:`.heartbeat`: heartbeat producer (0x1017) on every NMT path; heartbeat consumer (0x1016) with
  timeout (EMCY 0x8130) and "seen" / "lost" / "back" / "bootup" peer events.
- :mod:`.pdo_engine` (plans in :mod:`.pdo`): TPDOs on SYNC from the OD, RPDOs into the OD.
- :mod:`.sync_consumer`: SYNC processing (the producer is :mod:`.sync`).
- :mod:`.emcy_producer` (bookkeeping in :mod:`.emcy`): EMCY keeping 0x1001/0x1003, honouring 0x1015.
- :mod:`.sdo_gate`: canopen's SDO server gated by NMT, segmented-transfer tracking, block upload and
  block download (:mod:`.sdo_block`; canopen's server has none).
- :mod:`.od_access`: local OD access, the SDO write path (EDS range checks, validators, side effects),
  power-on values.
- Malformed frames (wrong length for a mapped PDO, SYNC, NMT, heartbeat or SDO) and frames with a
  COB-ID outside the contract (:mod:`.frames`) are counted and ignored; callbacks never kill the
  receive thread.

canopen's private state is touched in :mod:`.canopen_adapter` only; the services share
:class:`~telethermo.device.context.DeviceCore` (NMT state, lock, counters, timer thread).

Threads: frames are handled in the canopen notifier thread; timers (heartbeat, consumer timeouts,
EMCY inhibit, event timers) in the device's scheduler thread; the SYNC producer's own tick in the
thread that calls :meth:`telethermo.device.sync.SyncProducer.transmit`. SYNC processing,
RPDO commits and SDO writes are serialised by one lock. Callbacks must not block (never a blocking
SDO call from a callback).
"""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any, Callable

import canopen

from telethermo.device import canopen_adapter as adapter
from telethermo.device import emcy as emcy_mod
from telethermo.device.context import DeviceCore, DeviceStats, NmtCommand, NmtState
from telethermo.device.eds_info import EdsInfo, ObjectKey
from telethermo.device.emcy_producer import EmcyProducer
from telethermo.device.events import OdWriteError, PeerEvent, RpdoEvent, SyncTick, WriteEvent
from telethermo.device.frames import FrameWatch
from telethermo.device.heartbeat import Heartbeat
from telethermo.device.nmt import NmtSlave
from telethermo.device.od_access import OdAccess
from telethermo.device.pdo_engine import PdoEngine
from telethermo.device.sdo_gate import SdoGate
from telethermo.device.settings import DeviceSettings
from telethermo.device.sync_consumer import SyncConsumer

__all__ = [
    "Device",
    "DeviceStats",
    "NmtCommand",
    "NmtState",
    "OdWriteError",
    "PeerEvent",
    "RpdoEvent",
    "SyncTick",
    "WriteEvent",
]


class Device:
    """One CANopen node: ``Device(network, node_id, eds_path, settings=...)`` then ``start()``.

    ``network`` is a canopen.Network (connected or not yet); the device adds its LocalNode to it.
    The services are attributes (``nmt``, ``sdo``, ``pdos``, ``sync_consumer``, ``heartbeat``, ``emcy``,
    ``od_access``); the methods below are the device's whole public API.
    """

    #: sub-block size this server asks for in a block download (1..127 segments, CiA 301)
    SDO_BLOCK_SIZE = 127
    #: a block transfer whose client stays silent this long is aborted with 0x05040000 (s)
    SDO_BLOCK_TIMEOUT_S = 1.0
    #: a segmented transfer whose client stays silent this long is aborted with 0x05040000 (s)
    SDO_SEGMENT_TIMEOUT_S = 1.0

    def __init__(
        self,
        network: canopen.Network,
        node_id: int,
        eds: str | Path,
        *,
        settings: DeviceSettings | None = None,
        clock: Callable[[], float] = time.monotonic,
    ):
        if not 1 <= node_id <= 127:
            raise ValueError(f"node_id must be in 1..127, got {node_id}")
        self.network = network
        self.node_id = node_id
        self.eds_path = Path(eds)
        self.info = EdsInfo(self.eds_path)
        self.settings = settings or DeviceSettings()
        self.clock = clock
        self.stats = DeviceStats()
        self.node = adapter.GatedLocalNode(
            node_id,
            self.eds_path,
            known=self.info.vars,
            write=lambda var, data: self.od_access.sdo_write(var, data),
        )
        self.od = self.node.object_dictionary
        self.store: dict[int, dict[int, bytes]] = self.node.data_store
        self.core = core = DeviceCore(network, node_id, self.node, clock=clock, stats=self.stats)
        self.watch = FrameWatch(core, self.settings.known_node_ids)
        self.emcy = EmcyProducer(core)
        self.heartbeat = Heartbeat(core, self.emcy)
        self.pdos = PdoEngine(core, self.emcy, self.watch, lambda: self.sync_consumer.last_counter)
        self.tpdos, self.rpdos = self.pdos.tpdos, self.pdos.rpdos
        self.sync_consumer = SyncConsumer(core, self.pdos, self.emcy)
        self.sdo = SdoGate(
            core,
            self.node,
            block_size=lambda: self.SDO_BLOCK_SIZE,
            block_timeout_s=lambda: self.SDO_BLOCK_TIMEOUT_S,
            segment_timeout_s=lambda: self.SDO_SEGMENT_TIMEOUT_S,
        )
        self.nmt = NmtSlave(
            core, reset=self._reset_services, booted=self.heartbeat.arm, changed=self.pdos.nmt_changed
        )
        self.od_access = OdAccess(core, self.node, self.info, self.settings)
        for low, high, hook in (
            (0x1003, 0x1003, self.emcy.history_written),
            (0x1005, 0x1005, self.sync_consumer.cob_id_written),
            (0x1006, 0x1006, self.sync_consumer.period_written),
            (0x1016, 0x1016, self.heartbeat.consumers_written),
            (0x1017, 0x1017, self.heartbeat.producer_written),
            (0x1019, 0x1019, self.sync_consumer.overflow_written),
        ):
            self.od_access.on_write(low, high, hook)
        self.od_access.on_write(0x1400, 0x1BFF, self.pdos.param_written, restore=self.pdos.reconfigure)
        # wire into the network: replace LocalNode's NMT and SDO handlers by gated ones
        network.add_node(self.node)
        adapter.detach_default_handlers(network, self.node)
        network.subscribe(0, self.nmt.on_frame)
        network.subscribe(self.node.sdo.rx_cobid, self.sdo.on_frame)
        # first in line, before canopen's dispatcher: it flags 29-bit frames for the service handlers
        adapter.listen_first(network, self.watch)

    def _reset_services(self, whole: bool | None) -> None:
        """The services' part of an NMT boot (``whole``: see :meth:`NmtSlave.boot`), in this order."""
        self.sdo.reset()
        self.heartbeat.cancel()
        if whole is not None:
            self.od_access.install_defaults(lambda index: True if whole else 0x1000 <= index <= 0x1FFF)
        self.emcy.reset(whole)
        self.pdos.reconfigure()
        self.heartbeat.reconfigure(restart=True)
        self.sync_consumer.resubscribe()

    # ------------------------------------------------------------------ life cycle
    def start(self) -> None:
        """Power on: INITIALISING → boot-up → PRE-OPERATIONAL, heartbeat producer running.

        The power-on values were installed by the constructor; what the program wrote into the OD
        between the constructor and ``start()`` (its configuration) is kept. An NMT reset node later
        restores the power-on values (listen with ``add_nmt_listener`` to re-apply a configuration).
        """
        with self.core.lock:
            self.core.running = True
            self.nmt.boot(whole=None, command=None)

    def close(self) -> None:
        """Stop timers and leave the network (no more frames from this device).

        The device is then powered off: ``state`` is INITIALISING, SYNC processing returns None and
        a SYNC producer on it refuses to transmit. No NMT listener is called.
        """
        core = self.core
        core.running = False
        core.scheduler.stop()  # outside the lock: a running job may be waiting for it
        with core.lock:
            self.nmt.power_off()
            self.pdos.unsubscribe()
            self.heartbeat.unsubscribe()
            self.sync_consumer.unsubscribe()
            core.unsubscribe(0, self.nmt.on_frame)
            core.unsubscribe(self.node.sdo.rx_cobid, self.sdo.on_frame)
            adapter.stop_listening(self.network, self.watch)
            if self.network.nodes.get(self.node_id) is self.node:
                del self.network.nodes[self.node_id]

    def __enter__(self) -> "Device":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def state(self) -> NmtState:
        return self.core.state

    @property
    def lock(self) -> threading.RLock:
        """The device lock (re-entrant): held during SYNC processing, RPDO commits, SDO writes and
        NMT transitions. Hold it to act between two SYNCs (e.g. cut the current on shutdown)."""
        return self.core.lock

    @property
    def is_sync_producer(self) -> bool:
        return self.sync_consumer.is_producer

    @property
    def sync_cob_id(self) -> int:
        return self.sync_consumer.cob_id

    @property
    def known_cobids(self) -> frozenset[int]:
        """COB-IDs of the network's services (the broadcast ones, every node's, the valid PDOs')."""
        return frozenset(self.watch.known)

    # ------------------------------------------------------------------ callbacks
    def add_sync_handler(self, fn: Callable[[SyncTick], None]) -> None:
        """``fn(tick)`` on every SYNC in PRE-OPERATIONAL/OPERATIONAL, before the synchronous TPDOs
        are built (so what it writes into the OD goes out with this SYNC)."""
        self.sync_consumer.handlers.append(fn)

    def add_rpdo_listener(self, fn: Callable[[RpdoEvent], None]) -> None:
        """``fn(event)`` when an RPDO is accepted (notifier thread)."""
        self.pdos.listeners.append(fn)

    def add_peer_listener(self, fn: Callable[[PeerEvent], None]) -> None:
        """``fn(event)`` on heartbeat-consumer events (scheduler or notifier thread)."""
        self.heartbeat.listeners.append(fn)

    def add_nmt_listener(self, fn: Callable[[NmtState, NmtState, int | None], None]) -> None:
        """``fn(old, new, command)`` on every NMT state change (command None on power-on)."""
        self.nmt.listeners.append(fn)

    def add_write_listener(self, fn: Callable[[WriteEvent], None]) -> None:
        """``fn(event)`` after every accepted SDO write (notifier thread), with the device lock held:
        the store and the listeners are one step for a SYNC handler. Must not block."""
        self.od_access.write_listeners.append(fn)

    def add_write_validator(self, key: ObjectKey, fn: Callable[[Any], int | None]) -> None:
        """``fn(value) -> abort_code | None`` before an SDO write of object ``key`` is stored.

        Called in the SDO download path (notifier thread, device lock held) after the EDS range
        check, with the decoded value; returning an abort code (e.g.
        :data:`telethermo.cia301.ABORT_DEVICE_STATE`, 0x08000022, for a value the device
        cannot take in its present state) refuses the write: the client gets that SDO abort and the
        object keeps its value. ``None`` accepts. A validator that raises refuses the write with
        0x08000000 (general error) and counts a callback error. Local :meth:`write` calls of
        manufacturer objects (the program itself) are not validated. Must not block. Several
        validators of one object are called in the order they were added.
        """
        self.od_access.add_validator(key, fn)

    # ------------------------------------------------------------------ OD access (local)
    def read(self, key: ObjectKey) -> Any:
        """Decoded value of an object (name, "0x2000", "0x1018sub1", (index, sub))."""
        return self.od_access.read(key)

    def write(self, key: ObjectKey, value: Any, *, check: bool = True) -> None:
        """Set an object locally (no SDO). Communication objects (< 0x2000) get the same checks and
        side effects as an SDO write; others are range-checked when ``check`` (OdWriteError)."""
        self.od_access.write(key, value, check=check)

    def writer(self, key: ObjectKey) -> Callable[[Any], None]:
        """A fast unchecked setter for a manufacturer object written every cycle (measurements)."""
        return self.od_access.writer(key)

    def reader(self, key: ObjectKey) -> Callable[[], Any]:
        """A fast getter for an object read every cycle (peer values)."""
        return self.od_access.reader(key)

    # ------------------------------------------------------------------ NMT
    def nmt_command(self, command: int, node_id: int = 0) -> None:
        """Send an NMT command on the bus (as NMT master) and apply it here if it targets this node.

        A node never receives its own frames, so a node that commands "all nodes" (node_id 0) or
        itself must apply the command locally: this method does both.
        """
        self.nmt.command(command, node_id)

    # ------------------------------------------------------------------ SYNC, PDO
    def process_sync(self, counter: int | None) -> SyncTick | None:
        """Handle one SYNC: commit synchronous RPDOs, run the SYNC handlers, send the due TPDOs.

        Called for SYNC frames from the bus, and by the SYNC producer for its own SYNC (a node never
        receives its own frames). Returns None in STOPPED/INITIALISING (SYNC ignored).
        """
        return self.sync_consumer.process(counter)

    def rpdo_count(self, number: int = 1) -> int:
        """RPDOs of channel ``number`` accepted so far."""
        return self.pdos.rpdo_count(number)

    def wait_rpdo(self, number: int = 1, *, after: int, timeout: float) -> bool:
        """Block until more than ``after`` RPDOs of channel ``number`` were accepted; False on timeout.

        For a lockstep SYNC producer:
        ``n = dev.rpdo_count(1); sync.transmit(); dev.wait_rpdo(1, after=n, ...)``. Never call this from a
        callback (it would block the receive thread).
        """
        return self.pdos.wait_rpdo(number, after=after, timeout=timeout)

    def trigger_tpdo(self, number: int) -> None:
        """Event for TPDO ``number``: type 0 goes at the next SYNC, types 254/255 now
        (inhibit time permitting)."""
        self.pdos.trigger(number)

    # ------------------------------------------------------------------ heartbeat
    def peer_status(self, node_id: int) -> str:
        """ "unknown" (no heartbeat yet), "alive" or "lost" for a consumed peer."""
        return self.heartbeat.status(node_id)

    def peer_state(self, node_id: int) -> int | None:
        """Last NMT state code the peer reported in its heartbeat (None before the first)."""
        return self.heartbeat.peer_state(node_id)

    def send_heartbeat_now(self) -> None:
        """One heartbeat with the current state at once (e.g. the last one before a clean stop)."""
        self.heartbeat.send_now()

    # ------------------------------------------------------------------ EMCY
    def raise_emcy(
        self,
        code: int,
        *,
        data: bytes = b"",
        info16: int = 0,
        source: str = emcy_mod.APP,
        subject: int | None = None,
    ) -> None:
        """Record error ``code`` (0x1001, 0x1003) and send its EMCY (inhibit time permitting).

        ``source`` tells who holds the error (the program: the default; the device's heartbeat consumer
        and PDO-length check use their own); ``subject`` what it concerns (the heartbeat consumer: the
        lost node; a peer_lost trip should name its peer). A code held by another source already for
        the same subject (or with none named) is the same error still present, so no second frame or
        history entry; for another subject it is a new occurrence (see :mod:`.emcy`)."""
        self.emcy.raise_error(code, data=data, info16=info16, source=source, subject=subject)

    def clear_emcy(self, code: int, *, source: str = emcy_mod.APP) -> None:
        """``source`` no longer has error ``code``; the code stays active while another source holds
        it; when no error is left, send the error-reset EMCY (0x0000)."""
        self.emcy.clear(code, source=source)

    def reset_emcy(self) -> None:
        """Clear every active error and send the error-reset EMCY (history 0x1003 is kept)."""
        self.emcy.clear_all()

    @property
    def active_errors(self) -> tuple[int, ...]:
        return self.emcy.active
