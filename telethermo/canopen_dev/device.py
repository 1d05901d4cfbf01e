"""A CiA 301 device over canopen.LocalNode: the behaviour the library leaves out (DESIGN.md §4).

canopen 2.4's LocalNode gives an object dictionary, an SDO server and frame plumbing. This module
adds, per CiA 301:

- NMT slave: INITIALISING → boot-up → PRE-OPERATIONAL on power-on, reset node and reset
  communication; start / stop / enter pre-operational; SDO only in PRE-OPERATIONAL and OPERATIONAL,
  PDOs only in OPERATIONAL. Reset node restores every object, reset communication 0x1000..0x1FFF,
  to the power-on values (EDS defaults overridden by :class:`DeviceSettings`).
- Heartbeat producer (0x1017) on every NMT path; heartbeat consumer (0x1016) with timeout
  (EMCY 0x8130) and "seen" / "lost" / "back" / "bootup" peer events.
- PDOs (see :mod:`telethermo.canopen_dev.pdo`): TPDOs on SYNC from the OD, RPDOs into the OD.
- EMCY producer keeping 0x1001/0x1003 and honouring 0x1015 (see :mod:`telethermo.canopen_dev.emcy`).
- SDO writes range-checked against the EDS (REAL32 limits re-read from the text): abort
  0x06090030 (range exceeded, or NaN), 0x06090031 (too high), 0x06090032 (too low); the value is
  left unchanged.
- SDO block upload and block download (see :mod:`telethermo.canopen_dev.sdo_block`; canopen's
  server has none), through the same read and write paths as segmented transfers.
- Malformed frames (wrong length for a mapped PDO, SYNC, NMT, heartbeat or SDO) and frames with a
  COB-ID outside the contract are counted and ignored; callbacks never kill the receive thread.

Threads: frames are handled in the canopen notifier thread; timers (heartbeat, consumer timeouts,
EMCY inhibit, event timers) in the device's scheduler thread; the SYNC producer's own tick in the
thread that calls :meth:`telethermo.canopen_dev.sync.SyncProducer.transmit`. SYNC processing,
RPDO commits and SDO writes are serialised by one lock. Callbacks must not block (never a blocking
SDO call from a callback).
"""
from __future__ import annotations

import functools
import logging
import threading
import time
from dataclasses import dataclass
from enum import IntEnum
from pathlib import Path
from typing import Any, Callable

import can
import canopen
from canopen import objectdictionary as odmod
from canopen.sdo import SdoAbortedError

from telethermo.canopen_dev import emcy as emcy_mod
from telethermo.canopen_dev import pdo as pdo_mod
from telethermo.canopen_dev.eds_info import EdsInfo, VarInfo, parse_index_key
from telethermo.canopen_dev.scheduler import Scheduler
from telethermo.canopen_dev.sdo_block import BlockServer
from telethermo.canopen_dev.settings import DeviceSettings

logger = logging.getLogger(__name__)

ABORT_RANGE = 0x06090030
ABORT_INCOMPATIBLE = 0x06040043
ABORT_READ_ONLY = 0x06010002
ABORT_LENGTH = 0x06070010
ABORT_GENERAL = 0x08000000
ABORT_COMMAND_SPECIFIER = 0x05040001
ABORT_DEVICE_STATE = 0x08000022   # data cannot be transferred or stored because of the present device state

# diagnostics objects served live from DeviceStats (see bus_config/edsgen.py)
DIAG_OBJECTS = {0x2710: "malformed_frames", 0x2711: "unknown_cobid_frames", 0x2712: "callback_errors",
                0x2713: "sync_count", 0x2714: "rpdo_count", 0x2715: "peer_losses"}
PEER_ALIVE_INDEX = 0x2705


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


@dataclass(frozen=True, slots=True)
class SyncTick:
    """What a SYNC handler gets.

    Attributes:
        counter: the SYNC counter (1..0x1019) or None for a SYNC without counter.
        fresh_rpdos: numbers of the synchronous RPDOs whose data were written into the OD at this
            SYNC (i.e. received since the previous SYNC).
        operational: True in OPERATIONAL (TPDOs follow the handlers), False in PRE-OPERATIONAL.
    """

    counter: int | None
    fresh_rpdos: tuple[int, ...]
    operational: bool


@dataclass(frozen=True, slots=True)
class RpdoEvent:
    """An accepted RPDO: its number, named values, the last SYNC counter seen, receive time (s)."""

    number: int
    values: dict[str, float | int]
    sync_counter: int | None
    timestamp: float


@dataclass(frozen=True, slots=True)
class PeerEvent:
    """Heartbeat consumer event. ``kind``: "seen" (first heartbeat), "lost" (timeout), "back"
    (heartbeat after a loss), "bootup" (the peer sent a boot-up message), "state" (an alive peer's
    heartbeat reports another NMT state than its previous one, e.g. put into PRE-OPERATIONAL by
    another NMT master). ``state``: the peer's NMT state code from the heartbeat (None for "lost")."""

    node_id: int
    kind: str
    state: int | None


@dataclass(frozen=True, slots=True)
class WriteEvent:
    """A successful SDO write: where, the decoded value."""

    index: int
    subindex: int
    value: Any


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


class OdWriteError(ValueError):
    """A local write was refused; ``code`` is the SDO abort code a remote write would have got."""

    def __init__(self, message: str, code: int):
        super().__init__(message)
        self.code = code


class _Node(canopen.LocalNode):
    """LocalNode whose SDO writes go through the device (checks, side effects) before storing."""

    def __init__(self, node_id: int, od, device: "Device"):
        super().__init__(node_id, od)
        self._device = device

    def set_data(self, index: int, subindex: int, data: bytes, check_writable: bool = False) -> None:
        obj = self._find_object(index, subindex)
        if check_writable and not obj.writable:
            raise SdoAbortedError(ABORT_READ_ONLY)
        if (obj.data_type in odmod.NUMBER_TYPES and 8 * len(data) != len(obj)) \
                or (obj.data_type == odmod.BOOLEAN and len(data) != 1):
            raise SdoAbortedError(ABORT_LENGTH)
        self._device._sdo_write(obj, bytes(data))

    def _find_object(self, index: int, subindex: int):
        obj = super()._find_object(index, subindex)
        # canopen invents ARRAY entries past the last one and ignores the sub-index of a VAR
        if obj.subindex != subindex or (index, subindex) not in self._device.info.vars:
            raise SdoAbortedError(0x06090011)
        return obj


class _FrameWatch(can.Listener):
    """Counts frames whose COB-ID belongs to no service of the network's nodes."""

    def __init__(self, device: "Device"):
        self.device = device

    def on_message_received(self, msg: can.Message) -> None:
        # called before canopen's own listener (see Device.__init__): canopen dispatches by the bare
        # identifier, so a 29-bit frame whose ID happens to be a service's (0x000, 0x601, ...) would
        # reach that service's handler; the handlers look at this flag and ignore it
        self.device._extended = msg.is_extended_id
        if msg.is_error_frame:
            return
        if msg.is_extended_id or msg.arbitration_id not in self.device._known_cobids:
            self.device.stats.unknown_cobid_frames += 1

    def stop(self) -> None:
        pass


def _hb_source(node_id: int) -> str:
    """The EMCY source of the heartbeat consumer's error for one watched node."""
    return f"heartbeat{node_id}"


def _known_cobids(node_ids: tuple[int, ...]) -> set[int]:
    ids = node_ids or tuple(range(1, 128))
    out = {0x000, 0x080, 0x100, 0x7E4, 0x7E5}
    for n in ids:
        out |= {base + n for base in (0x080, 0x180, 0x200, 0x280, 0x300, 0x380, 0x400, 0x480, 0x500,
                                      0x580, 0x600, 0x700)}
    return out


class Device:
    """One CANopen node: ``Device(network, node_id, eds_path, settings=...)`` then ``start()``.

    ``network`` is a canopen.Network (connected or not yet); the device adds its LocalNode to it.
    """

    #: sub-block size this server asks for in a block download (1..127 segments, CiA 301)
    SDO_BLOCK_SIZE = 127
    #: a block transfer whose client stays silent this long is aborted with 0x05040000 (s)
    SDO_BLOCK_TIMEOUT_S = 1.0

    def __init__(self, network: canopen.Network, node_id: int, eds: str | Path, *,
                 settings: DeviceSettings | None = None, clock: Callable[[], float] = time.monotonic):
        if not 1 <= node_id <= 127:
            raise ValueError(f"node_id must be in 1..127, got {node_id}")
        self.network = network
        self.node_id = node_id
        self.eds_path = Path(eds)
        self.info = EdsInfo(self.eds_path)
        self.settings = settings or DeviceSettings()
        self.clock = clock
        self.stats = DeviceStats()
        self.node = _Node(node_id, canopen.import_od(str(self.eds_path), node_id), self)
        self.od = self.node.object_dictionary
        self.store: dict[int, dict[int, bytes]] = self.node.data_store
        self._lock = threading.RLock()
        self._rpdo_cond = threading.Condition()
        self._state = NmtState.INITIALISING
        self._running = False
        self._scheduler = Scheduler(f"canopen-dev-{node_id}", clock)
        self._sync_handlers: list[Callable[[SyncTick], None]] = []
        self._rpdo_listeners: list[Callable[[RpdoEvent], None]] = []
        self._peer_listeners: list[Callable[[PeerEvent], None]] = []
        self._nmt_listeners: list[Callable[[NmtState, NmtState, int | None], None]] = []
        self._write_listeners: list[Callable[[WriteEvent], None]] = []
        self._write_validators: dict[tuple[int, int], list[Callable[[Any], int | None]]] = {}
        self._last_sync_counter: int | None = None
        self._slots: dict[Any, tuple[int, int, Any, VarInfo | None]] = {}
        # EMCY
        self._emcy = emcy_mod.EmcyState()
        self._emcy_queue: list[tuple[int, int, bytes]] = []
        self._emcy_last = -1e18
        # heartbeat
        self._hb_next = 0.0
        self._consumers: dict[int, float] = {}       # peer node-ID -> timeout s
        self._peer_status: dict[int, str] = {}       # "unknown" / "alive" / "lost"
        self._peer_state: dict[int, int | None] = {}
        self._peer_seen: dict[int, float] = {}
        self._hb_subs: list[tuple[int, Callable]] = []
        # PDO plans
        self.tpdos: dict[int, pdo_mod.PdoPlan] = {}
        self.rpdos: dict[int, pdo_mod.PdoPlan] = {}
        for i in range(512):
            if 0x1800 + i in self.od and 0x1A00 + i in self.od:
                self.tpdos[i + 1] = pdo_mod.PdoPlan(i + 1, True, 0x1800 + i, 0x1A00 + i)
            if 0x1400 + i in self.od and 0x1600 + i in self.od:
                self.rpdos[i + 1] = pdo_mod.PdoPlan(i + 1, False, 0x1400 + i, 0x1600 + i)
        self._sync_tpdos: list[pdo_mod.PdoPlan] = []
        self._sync_rpdos: list[pdo_mod.PdoPlan] = []
        self._rpdo_subs: list[tuple[int, Callable]] = []
        self._rpdo_counts: dict[int, int] = {n: 0 for n in self.rpdos}
        self._sync_sub: tuple[int, Callable] | None = None
        self._defaults = self._power_on_values()
        self._install_defaults(lambda index: True)
        self._known_base = _known_cobids(self.settings.known_node_ids)
        self._known_cobids = set(self._known_base)
        # wire into the network: replace LocalNode's NMT and SDO handlers by gated ones
        network.add_node(self.node)
        network.unsubscribe(0, self.node.nmt.on_command)
        network.unsubscribe(self.node.sdo.rx_cobid, self.node.sdo.on_request)
        network.subscribe(0, self._on_nmt_frame)
        network.subscribe(self.node.sdo.rx_cobid, self._on_sdo_frame)
        self.node.add_read_callback(self._on_read)
        self._extended = False   # the frame being dispatched has a 29-bit ID (set by the frame watch)
        self._sdo_transfer: str | None = None   # segmented SDO transfer in progress: "up", "down" or None
        # block transfers (canopen's server has none): reads and writes through the same paths as its
        # segmented transfers (read callbacks; set_data -> _sdo_write with range checks and validators)
        self._sdo_block = BlockServer(lambda i, s: self.node.get_data(i, s, check_readable=True),
                                      lambda i, s, d: self.node.set_data(i, s, d, check_writable=True),
                                      self._sdo_block_check)
        self._sdo_block_deadline = 0.0
        self._watch = _FrameWatch(self)
        # first in line, before canopen's dispatcher: it flags 29-bit frames for the service handlers
        if network.notifier is not None:
            network.notifier.listeners.insert(0, self._watch)
        else:
            network.listeners.insert(0, self._watch)

    # ------------------------------------------------------------------ life cycle
    def start(self) -> None:
        """Power on: INITIALISING → boot-up → PRE-OPERATIONAL, heartbeat producer running.

        The power-on values were installed by the constructor; what the program wrote into the OD
        between the constructor and ``start()`` (its configuration) is kept. An NMT reset node later
        restores the power-on values (listen with ``add_nmt_listener`` to re-apply a configuration).
        """
        with self._lock:
            self._running = True
            self._boot(whole=None, command=None)

    def close(self) -> None:
        """Stop timers and leave the network (no more frames from this device).

        The device is then powered off: ``state`` is INITIALISING, SYNC processing returns None and
        a SYNC producer on it refuses to transmit. No NMT listener is called.
        """
        self._running = False
        self._scheduler.stop()  # outside the lock: a running job may be waiting for it
        with self._lock:
            self._state = NmtState.INITIALISING
            self.node.nmt._state = 0
            self._unsubscribe_pdos()
            self._unsubscribe_heartbeats()
            if self._sync_sub:
                try:
                    self.network.unsubscribe(*self._sync_sub)
                except (KeyError, ValueError):
                    pass
                self._sync_sub = None
            for cob, cb in ((0, self._on_nmt_frame), (self.node.sdo.rx_cobid, self._on_sdo_frame)):
                try:
                    self.network.unsubscribe(cob, cb)
                except (KeyError, ValueError):
                    pass
            if self.network.notifier is not None:
                try:
                    self.network.notifier.remove_listener(self._watch)
                except ValueError:
                    pass
            if self._watch in self.network.listeners:
                self.network.listeners.remove(self._watch)
            if self.network.nodes.get(self.node_id) is self.node:
                del self.network.nodes[self.node_id]

    def __enter__(self) -> "Device":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @property
    def state(self) -> NmtState:
        return self._state

    @property
    def lock(self) -> threading.RLock:
        """The device lock (re-entrant): held during SYNC processing, RPDO commits, SDO writes and
        NMT transitions. Hold it to act between two SYNCs (e.g. cut the current on shutdown)."""
        return self._lock

    @property
    def is_sync_producer(self) -> bool:
        return bool(self._u(0x1005, 0) & (1 << 30))

    @property
    def sync_cob_id(self) -> int:
        return self._u(0x1005, 0) & 0x7FF

    # ------------------------------------------------------------------ callbacks
    def add_sync_handler(self, fn: Callable[[SyncTick], None]) -> None:
        """``fn(tick)`` on every SYNC in PRE-OPERATIONAL/OPERATIONAL, before the synchronous TPDOs
        are built (so what it writes into the OD goes out with this SYNC)."""
        self._sync_handlers.append(fn)

    def add_rpdo_listener(self, fn: Callable[[RpdoEvent], None]) -> None:
        """``fn(event)`` when an RPDO is accepted (notifier thread)."""
        self._rpdo_listeners.append(fn)

    def add_peer_listener(self, fn: Callable[[PeerEvent], None]) -> None:
        """``fn(event)`` on heartbeat-consumer events (scheduler or notifier thread)."""
        self._peer_listeners.append(fn)

    def add_nmt_listener(self, fn: Callable[[NmtState, NmtState, int | None], None]) -> None:
        """``fn(old, new, command)`` on every NMT state change (command None on power-on)."""
        self._nmt_listeners.append(fn)

    def add_write_listener(self, fn: Callable[[WriteEvent], None]) -> None:
        """``fn(event)`` after every accepted SDO write (notifier thread), with the device lock held:
        the store and the listeners are one step for a SYNC handler. Must not block."""
        self._write_listeners.append(fn)

    def add_write_validator(self, key, fn: Callable[[Any], int | None]) -> None:
        """``fn(value) -> abort_code | None`` before an SDO write of object ``key`` is stored.

        Called in the SDO download path (notifier thread, device lock held) after the EDS range
        check, with the decoded value; returning an abort code (e.g. :data:`ABORT_DEVICE_STATE`,
        0x08000022, for a value the device cannot take in its present state) refuses the write:
        the client gets that SDO abort and the object keeps its value. ``None`` accepts. A validator
        that raises refuses the write with 0x08000000 (general error) and counts a callback error.
        Local :meth:`write` calls of manufacturer objects (the program itself) are not validated.
        Must not block. Several validators of one object are called in the order they were added.
        """
        index, sub, _, _ = self._slot(key)
        self._write_validators.setdefault((index, sub), []).append(fn)

    def _validate_write(self, index: int, sub: int, value: Any) -> int | None:
        for fn in self._write_validators.get((index, sub), ()):
            try:
                code = fn(value)
            except Exception:
                self._callback_failed(fn)
                return ABORT_GENERAL
            if code is not None:
                return int(code)
        return None

    def _call(self, fns: list, *args) -> None:
        for fn in fns:
            try:
                fn(*args)
            except Exception:  # a callback must never kill the receive thread
                self._callback_failed(fn)

    def _callback_failed(self, fn) -> None:
        """Count a failed callback; log the first 5 with their traceback, then every 1000th."""
        self.stats.callback_errors += 1
        n = self.stats.callback_errors
        if n <= 5 or n % 1000 == 0:
            logger.exception("node %d: callback %r failed (%d so far)", self.node_id, fn, n)

    # ------------------------------------------------------------------ OD access (local)
    def _slot(self, key) -> tuple[int, int, Any, VarInfo | None]:
        slot = self._slots.get(key)
        if slot is None:
            idx = parse_index_key(key)
            info = self.info.vars.get(idx) if idx is not None else self.info.get(key)
            if info is None:
                raise KeyError(f"{self.eds_path.name}: no object 0x{idx[0]:04X} sub {idx[1]}")
            var = self.node._find_object(info.index, info.subindex)
            slot = (info.index, info.subindex, var, info)
            self._slots[key] = slot
        return slot

    def read(self, key) -> Any:
        """Decoded value of an object (name, "0x2000", "0x1018sub1", (index, sub))."""
        index, sub, var, _ = self._slot(key)
        return var.decode_raw(self.node.get_data(index, sub))

    def write(self, key, value, *, check: bool = True) -> None:
        """Set an object locally (no SDO). Communication objects (< 0x2000) get the same checks and
        side effects as an SDO write; others are range-checked when ``check`` (OdWriteError)."""
        index, sub, var, info = self._slot(key)
        data = var.encode_raw(value)
        if index < 0x2000:
            try:
                self._sdo_write(var, data)
            except SdoAbortedError as exc:
                raise OdWriteError(f"{info.key if info else hex(index)} = {value!r} refused: {exc}", exc.code) from None
            return
        if check and info is not None and (info.low is not None or info.high is not None):
            code = self.info.check(info, var.decode_raw(data))
            if code is not None:
                raise OdWriteError(f"{info.key} = {value!r} is outside {info.range_text()}", code)
        self.store[index][sub] = data

    def writer(self, key) -> Callable[[Any], None]:
        """A fast unchecked setter for a manufacturer object written every cycle (measurements)."""
        index, sub, var, _ = self._slot(key)
        if index < 0x2000:
            raise ValueError("writer() is for manufacturer objects; use write() for communication objects")
        st = var.STRUCT_TYPES.get(var.data_type)
        cell = self.store[index]
        if st is None:
            return lambda value: cell.__setitem__(sub, var.encode_raw(value))
        pack = st.pack
        if var.data_type == odmod.BOOLEAN:
            return lambda value: cell.__setitem__(sub, pack(bool(value)))
        return lambda value: cell.__setitem__(sub, pack(value))

    def reader(self, key) -> Callable[[], Any]:
        """A fast getter for an object read every cycle (peer values)."""
        index, sub, var, _ = self._slot(key)
        st = var.STRUCT_TYPES.get(var.data_type)
        if index in DIAG_OBJECTS or st is None:
            return lambda: self.read(key)
        cell, unpack = self.store[index], st.unpack
        return lambda: unpack(cell[sub])[0]

    def _u(self, index: int, sub: int) -> int:
        return int.from_bytes(self.store[index][sub], "little")

    def _on_read(self, index: int, subindex: int, od) -> Any:
        name = DIAG_OBJECTS.get(index)
        if name is not None:
            return getattr(self.stats, name) & 0xFFFFFFFF
        return None

    # ------------------------------------------------------------------ defaults, resets
    def _power_on_values(self) -> dict[tuple[int, int], bytes]:
        values: dict[tuple[int, int], bytes] = {}
        for obj in self.od.values():
            members = [obj] if isinstance(obj, odmod.ODVariable) else list(obj.values())
            for var in members:
                raw = var.value if var.value is not None else var.default
                try:
                    data = var.encode_raw(raw) if raw is not None else bytes(max(1, len(var) // 8))
                except Exception:
                    data = bytes(max(1, len(var) // 8))
                values[(var.index, var.subindex)] = data
        for (index, sub), v in self.settings.overrides().items():
            var = self.node._find_object(index, sub)
            values[(index, sub)] = var.encode_raw(v)
        if self.settings.sync_producer is not None:
            cob = int.from_bytes(values[(0x1005, 0)], "little") & ~(1 << 30)
            cob |= (1 << 30) if self.settings.sync_producer else 0
            values[(0x1005, 0)] = cob.to_bytes(4, "little")
        return values

    def _install_defaults(self, which: Callable[[int], bool]) -> None:
        for (index, sub), data in self._defaults.items():
            if which(index):
                self.store.setdefault(index, {})[sub] = data

    def _boot(self, *, whole: bool | None, command: int | None) -> None:
        """INITIALISING → boot-up → PRE-OPERATIONAL. ``whole``: True reset node (every object back to
        its power-on value), False reset communication (0x1000..0x1FFF), None power-on (keep the OD)."""
        old = self._state
        self._state = NmtState.INITIALISING
        self.node.nmt._state = 0
        self._sdo_transfer = None
        self._sdo_block.reset()
        self._scheduler.cancel("hb")
        if whole is None:
            pass
        elif whole:
            self._install_defaults(lambda index: True)
            self._emcy = emcy_mod.EmcyState()
        else:
            self._install_defaults(lambda index: 0x1000 <= index <= 0x1FFF)
            self._emcy.history.clear()
            self.store[0x1001][0] = bytes([self._emcy.register])
        self._emcy_queue.clear()
        self._scheduler.cancel("emcy")
        self._reconfigure_pdos()
        self._reconfigure_heartbeat_consumers(restart=True)
        self._resubscribe_sync()
        if old is not NmtState.INITIALISING:
            self._call(self._nmt_listeners, old, NmtState.INITIALISING, command)
        self._send(0x700 + self.node_id, b"\x00")  # boot-up
        self._set_state(NmtState.PRE_OPERATIONAL, command, old=NmtState.INITIALISING)
        self._arm_heartbeat(first=True)

    # ------------------------------------------------------------------ NMT
    def nmt_command(self, command: int, node_id: int = 0) -> None:
        """Send an NMT command on the bus (as NMT master) and apply it here if it targets this node.

        A node never receives its own frames, so a node that commands "all nodes" (node_id 0) or
        itself must apply the command locally: this method does both.
        """
        command = int(command)
        if command not in NmtCommand._value2member_map_:
            raise ValueError(f"unknown NMT command 0x{command:02X}")
        self._send(0x000, bytes([command, node_id]))
        if node_id in (0, self.node_id):
            self._apply_nmt(command)

    def _on_nmt_frame(self, can_id: int, data: bytes, timestamp: float) -> None:
        if self._extended:
            return  # a 29-bit ID is no service of ours (counted as unknown)
        if len(data) != 2:
            self.stats.malformed_frames += 1
            return
        command, target = data[0], data[1]
        if target not in (0, self.node_id):
            return
        if command not in NmtCommand._value2member_map_:
            self.stats.malformed_frames += 1
            return
        self._apply_nmt(command)

    def _apply_nmt(self, command: int) -> None:
        if not self._running:
            return
        with self._lock:
            if command == NmtCommand.RESET_NODE:
                self._boot(whole=True, command=command)
            elif command == NmtCommand.RESET_COMMUNICATION:
                self._boot(whole=False, command=command)
            elif command == NmtCommand.START:
                self._set_state(NmtState.OPERATIONAL, command)
            elif command == NmtCommand.STOP:
                self._set_state(NmtState.STOPPED, command)
            elif command == NmtCommand.ENTER_PRE_OPERATIONAL:
                self._set_state(NmtState.PRE_OPERATIONAL, command)

    def _set_state(self, new: NmtState, command: int | None, old: NmtState | None = None) -> None:
        old = self._state if old is None else old
        self._state = new
        self.node.nmt._state = int(new)
        if new != NmtState.OPERATIONAL or old != NmtState.OPERATIONAL:
            for rp in self.rpdos.values():
                rp.pending = None
        if new == NmtState.OPERATIONAL and old != NmtState.OPERATIONAL:
            overflow = self._u(0x1019, 0)
            for tp in self.tpdos.values():
                tp.countdown = tp.trans_type if 1 <= tp.trans_type <= 240 else 0
                tp.waiting_start = bool(tp.sync_start and overflow)
                tp.triggered = False
                self._arm_event_timer(tp)
        if new != NmtState.OPERATIONAL:
            self._scheduler.cancel_prefix("tpdo")
        if new != old or command is not None:
            self._call(self._nmt_listeners, old, new, command)

    # ------------------------------------------------------------------ SDO
    def _on_sdo_frame(self, can_id: int, data: bytes, timestamp: float) -> None:
        if self._extended:
            return  # a 29-bit ID is no service of ours (counted as unknown)
        if len(data) != 8:
            self.stats.malformed_frames += 1
            return
        if self._state in (NmtState.PRE_OPERATIONAL, NmtState.OPERATIONAL):
            sdo = self.node.sdo
            if sdo._index is None:
                # canopen's server packs _index/_subindex into its abort frame: None before the first
                # transfer made an invalid first request (e.g. command specifier 7) raise instead of abort
                sdo._index, sdo._subindex = 0, 0
            if self._sdo_block_frame(data):
                return
            # canopen's server keeps no transfer state: a segment request with no segmented transfer in
            # progress makes it raise (TypeError on a None buffer) or re-use an old buffer; CiA 301 wants
            # abort 0x05040001 (client/server command specifier not valid)
            ccs = data[0] & 0xE0
            if ccs in (0x00, 0x60) and self._sdo_transfer != ("down" if ccs == 0x00 else "up"):
                self._sdo_transfer = None
                sdo.abort(ABORT_COMMAND_SPECIFIER)
                return
            before = sdo._buffer
            try:
                sdo.on_request(can_id, data, timestamp)
            except Exception:  # never into the notifier (canopen would drop the rest of the frame's callbacks)
                self._callback_failed(sdo.on_request)
                self._sdo_transfer = None
                return
            if ccs in (0x40, 0xA0):      # initiate upload: segmented if it filled a new buffer
                self._sdo_transfer = "up" if sdo._buffer is not before and sdo._buffer else None
            elif ccs == 0x20:            # initiate download: segmented unless expedited (and not aborted)
                self._sdo_transfer = "down" if not data[0] & 0x02 and sdo._buffer is not before else None
            elif ccs == 0x60 and not sdo._buffer:
                self._sdo_transfer = None   # the last segment went out
            elif ccs == 0x00 and data[0] & 0x01:
                self._sdo_transfer = None   # the last segment came in
            elif ccs == 0x80:
                self._sdo_transfer = None   # the client aborted

    def _sdo_block_frame(self, data: bytes) -> bool:
        """Serve a block transfer frame (CiA 301 §7.2.4.3.9 ff., :mod:`.sdo_block`); False if canopen's
        server is to serve the frame.

        Block frames: an initiate block upload/download (ccs 5/6), the client's start/acknowledge/end
        (ccs 5) of an open block upload, and every frame but an abort (0x80) during a block download
        (its segments carry ``c | seqno`` in byte 0, no command specifier). Any other frame ends an
        open block transfer (one transfer per channel) and goes to canopen's server as before. A
        protocol switch (the client's pst allows a normal upload) also goes to canopen's server, whose
        block upload is a normal upload.
        """
        block = self._sdo_block
        ccs = data[0] & 0xE0
        if not (ccs in (0xA0, 0xC0) or (block.direction == "download" and data[0] != 0x80)):
            if block.direction is not None:
                with self._lock:
                    block.reset()
            return False
        self._sdo_transfer = None   # a block initiate ends a segmented transfer too
        with self._lock:
            block.blksize = self.SDO_BLOCK_SIZE
            try:
                frames = block.on_request(data)
            except Exception:  # never into the notifier: count it, abort the transfer
                self._callback_failed(block.on_request)
                frames = [block.abort(ABORT_GENERAL)]
            if block.direction is not None:
                self._sdo_block_deadline = self.clock() + self.SDO_BLOCK_TIMEOUT_S
                self._scheduler.set("sdo-block", self._sdo_block_deadline, self._sdo_block_timeout)
        if frames is None:
            return False
        for frame in frames:
            self._send(self.node.sdo.tx_cobid, frame)
        return True

    def _sdo_block_check(self, index: int, subindex: int) -> None:
        """At a block download's initiate: refuse a missing (0x06020000/0x06090011) or read-only
        (0x06010002) object before the client sends its data."""
        if not self.node._find_object(index, subindex).writable:
            raise SdoAbortedError(ABORT_READ_ONLY)

    def _sdo_block_timeout(self) -> None:
        """Scheduler job: a block transfer idle for ``SDO_BLOCK_TIMEOUT_S`` is aborted with 0x05040000
        (silently outside PRE-OPERATIONAL/OPERATIONAL, where the device sends no SDO)."""
        with self._lock:
            if self._sdo_block.direction is None or self.clock() < self._sdo_block_deadline:
                return   # finished, or a frame came meanwhile (it re-armed the job)
            frame = self._sdo_block.timeout()
            serving = self._running and self._state in (NmtState.PRE_OPERATIONAL, NmtState.OPERATIONAL)
        if serving and frame is not None:
            self._send(self.node.sdo.tx_cobid, frame)

    def _sdo_write(self, var, data: bytes) -> None:
        """Check, store and apply a write (SDO or local to a communication object)."""
        index, sub = var.index, var.subindex
        info = self.info.vars.get((index, sub))
        value = var.decode_raw(data)
        with self._lock:
            if var.data_type == odmod.BOOLEAN and data[:1] not in (b"\x00", b"\x01"):
                raise SdoAbortedError(ABORT_RANGE)   # CiA 301 BOOLEAN: 0 FALSE, 1 TRUE, nothing else
            if info is not None and var.data_type in odmod.NUMBER_TYPES:
                code = self.info.check(info, value)
                if code is not None:
                    raise SdoAbortedError(code)
            if self._write_validators:
                code = self._validate_write(index, sub, value)
                if code is not None:
                    raise SdoAbortedError(code)
            old = self.store[index].get(sub)
            self.store[index][sub] = data
            try:
                self._after_write(index, sub, value, old)
            except SdoAbortedError:
                if old is None:
                    del self.store[index][sub]
                else:
                    self.store[index][sub] = old
                self._after_write_restore(index)
                raise
            # under the lock, atomically with the store: no SYNC handler runs between the two
            if self._write_listeners:
                self._call(self._write_listeners, WriteEvent(index, sub, value))

    def _after_write_restore(self, index: int) -> None:
        if 0x1400 <= index <= 0x1BFF:
            self._reconfigure_pdos()

    def _after_write(self, index: int, sub: int, value: Any, old: bytes | None) -> None:
        if index == 0x1003:
            if sub != 0 or value != 0:
                raise SdoAbortedError(ABORT_RANGE)
            self._emcy.history.clear()
            self._store_emcy()
        elif index == 0x1005:
            if value & (1 << 29):
                # 29-bit SYNC is not supported (as in CANopenNode's OD_write_1005 / CO_ODF_1005: "only
                # 11-bit CAN identifier is supported", 0x06090030): refuse rather than keep an 11-bit
                # SYNC behind an OD that says 29-bit
                raise SdoAbortedError(ABORT_RANGE)
            self._resubscribe_sync()
        elif index == 0x1016:
            entries = [self._u(0x1016, s) for s in self.store[0x1016] if s > 0]
            ids = [(e >> 16) & 0xFF for e in entries if (e >> 16) & 0xFF and e & 0xFFFF]
            if len(ids) != len(set(ids)):
                raise SdoAbortedError(ABORT_INCOMPATIBLE)
            self._reconfigure_heartbeat_consumers()
        elif index == 0x1017:
            self._arm_heartbeat(first=True)
        elif index == 0x1019:
            if value == 1:
                raise SdoAbortedError(ABORT_RANGE)
            if self._u(0x1006, 0) != 0:
                # CiA 301: 0x1019 may be changed only while the communication cycle period 0x1006 is 0
                # (CANopenNode's OD_write_1019: ODR_DATA_DEV_STATE)
                raise SdoAbortedError(ABORT_DEVICE_STATE)
        elif 0x1400 <= index <= 0x1BFF:
            self._pdo_param_written(index, sub, value, old)

    # ------------------------------------------------------------------ PDO
    def _pdo_param_written(self, index: int, sub: int, value: int, old: bytes | None) -> None:
        tx = index >= 0x1800
        is_map = (0x1600 <= index <= 0x17FF) or index >= 0x1A00
        number = (index & 0x1FF) + 1
        plans = self.tpdos if tx else self.rpdos
        plan = plans.get(number)
        if plan is None:
            return
        if not is_map:
            pdo_mod.check_comm_write(plan, sub, int(value))  # ``plan`` still holds the values before this write
        elif sub > 0 and value:
            pdo_mod.mappable(self.node, value >> 16, (value >> 8) & 0xFF, value & 0xFF, tx=tx)
        elif sub == 0 and value > 8:
            raise SdoAbortedError(pdo_mod.ABORT_PDO_TOO_LONG)
        self._reconfigure_pdos()

    def _reconfigure_pdos(self) -> None:
        self._unsubscribe_pdos()
        for plan in list(self.tpdos.values()) + list(self.rpdos.values()):
            pdo_mod.compile_plan(plan, self.store, self.node)
            if plan.tx and 1 <= plan.trans_type <= 240:
                plan.countdown = min(plan.countdown, plan.trans_type) if plan.countdown > 0 else plan.trans_type
        self._sync_tpdos = [p for p in self.tpdos.values() if p.valid and p.trans_type <= 240]
        self._sync_rpdos = [p for p in self.rpdos.values() if p.valid and p.trans_type <= 240]
        self._known_cobids = set(self._known_base)
        for plan in self.tpdos.values():
            if plan.valid:
                self._known_cobids.add(plan.cob_id)
        for plan in self.rpdos.values():
            if plan.valid:
                cb = functools.partial(self._on_rpdo_frame, plan)
                self.network.subscribe(plan.cob_id, cb)
                self._rpdo_subs.append((plan.cob_id, cb))
                self._known_cobids.add(plan.cob_id)
        if self._state == NmtState.OPERATIONAL:
            for tp in self.tpdos.values():
                self._arm_event_timer(tp)

    def _unsubscribe_pdos(self) -> None:
        for cob, cb in self._rpdo_subs:
            try:
                self.network.unsubscribe(cob, cb)
            except (KeyError, ValueError):
                pass
        self._rpdo_subs = []

    def _on_rpdo_frame(self, plan: pdo_mod.PdoPlan, can_id: int, data: bytes, timestamp: float) -> None:
        if self._extended:
            return  # a 29-bit ID is no service of ours (counted as unknown)
        if self._state != NmtState.OPERATIONAL:
            self.stats.rpdo_ignored += 1
            return
        if len(data) != plan.length:
            self.stats.malformed_frames += 1
            if not plan.bad_length:
                plan.bad_length = True
                code = emcy_mod.EMCY_PDO_LENGTH if len(data) < plan.length else emcy_mod.EMCY_PDO_LENGTH_EXCEEDED
                self.raise_emcy(code, data=bytes([plan.number]), source=f"pdo-length{plan.number}")
            return
        data = bytes(data)
        with self._lock:
            if plan.synchronous:
                plan.pending = data
            else:
                plan.unpack_into_store(data)
            self.stats.rpdo_count += 1
        if plan.bad_length:
            plan.bad_length = False
            for code in (emcy_mod.EMCY_PDO_LENGTH, emcy_mod.EMCY_PDO_LENGTH_EXCEEDED):
                self.clear_emcy(code, source=f"pdo-length{plan.number}")
        with self._rpdo_cond:
            self._rpdo_counts[plan.number] += 1
            self._rpdo_cond.notify_all()
        if self._rpdo_listeners:
            self._call(self._rpdo_listeners,
                       RpdoEvent(plan.number, plan.decode(data), self._last_sync_counter, timestamp))

    def rpdo_count(self, number: int = 1) -> int:
        """RPDOs of channel ``number`` accepted so far."""
        return self._rpdo_counts[number]

    def wait_rpdo(self, number: int = 1, *, after: int, timeout: float) -> bool:
        """Block until more than ``after`` RPDOs of channel ``number`` were accepted; False on timeout.

        For a lockstep SYNC producer: ``n = dev.rpdo_count(1); sync.transmit(); dev.wait_rpdo(1, after=n, ...)``.
        Never call this from a callback (it would block the receive thread).
        """
        with self._rpdo_cond:
            return self._rpdo_cond.wait_for(lambda: self._rpdo_counts[number] > after, timeout)

    def trigger_tpdo(self, number: int) -> None:
        """Event for TPDO ``number``: type 0 goes at the next SYNC, types 254/255 now (inhibit time permitting)."""
        tp = self.tpdos[number]
        if self._state != NmtState.OPERATIONAL or not tp.valid:
            return
        if tp.trans_type == 0:
            tp.triggered = True
        elif tp.trans_type >= 254:
            self._send_event_tpdo(tp)

    def _send_event_tpdo(self, tp: pdo_mod.PdoPlan) -> None:
        if self._state != NmtState.OPERATIONAL or not tp.valid:
            return
        now = self.clock()
        allowed = tp.last_sent + tp.inhibit_100us * 1e-4
        if now < allowed:
            self._scheduler.set(f"tpdo-inhibit{tp.number}", allowed, lambda: self._send_event_tpdo(tp))
            return
        tp.last_sent = now
        self._send_tpdo(tp)
        self._arm_event_timer(tp)

    def _arm_event_timer(self, tp: pdo_mod.PdoPlan) -> None:
        if tp.valid and tp.trans_type >= 254 and tp.event_timer_ms and self._state == NmtState.OPERATIONAL:
            self._scheduler.set(f"tpdo-event{tp.number}", self.clock() + tp.event_timer_ms * 1e-3,
                                lambda: self._send_event_tpdo(tp))

    def _send_tpdo(self, tp: pdo_mod.PdoPlan) -> None:
        self._send(tp.cob_id, tp.pack())
        self.stats.tpdo_sent += 1

    # ------------------------------------------------------------------ SYNC
    def _resubscribe_sync(self) -> None:
        if self._sync_sub:
            try:
                self.network.unsubscribe(*self._sync_sub)
            except (KeyError, ValueError):
                pass
        self._sync_sub = (self.sync_cob_id, self._on_sync_frame)
        self.network.subscribe(*self._sync_sub)

    def _on_sync_frame(self, can_id: int, data: bytes, timestamp: float) -> None:
        if self._extended:
            return  # a 29-bit ID is no service of ours (counted as unknown)
        if len(data) > 1:
            self.stats.malformed_frames += 1
            return
        self.process_sync(data[0] if data else None)

    def process_sync(self, counter: int | None) -> SyncTick | None:
        """Handle one SYNC: commit synchronous RPDOs, run the SYNC handlers, send the due TPDOs.

        Called for SYNC frames from the bus, and by the SYNC producer for its own SYNC (a node never
        receives its own frames). Returns None in STOPPED/INITIALISING (SYNC ignored).
        """
        state = self._state
        if state is not NmtState.OPERATIONAL and state is not NmtState.PRE_OPERATIONAL:
            return None
        with self._lock:
            self.stats.sync_count += 1
            self._last_sync_counter = counter
            fresh: tuple[int, ...] = ()
            operational = state is NmtState.OPERATIONAL
            if operational:
                for rp in self._sync_rpdos:
                    if rp.pending is not None:
                        rp.unpack_into_store(rp.pending)
                        rp.pending = None
                        fresh += (rp.number,)
            tick = SyncTick(counter, fresh, operational)
            for fn in self._sync_handlers:
                try:
                    fn(tick)
                except Exception:
                    self._callback_failed(fn)
            if self._state is NmtState.OPERATIONAL:
                for tp in self._sync_tpdos:
                    if tp.trans_type == 0:
                        if tp.triggered:
                            tp.triggered = False
                            self._send_tpdo(tp)
                        continue
                    if tp.waiting_start:
                        if counter != tp.sync_start:
                            continue
                        tp.waiting_start = False
                        tp.countdown = 1
                    tp.countdown -= 1
                    if tp.countdown <= 0:
                        tp.countdown = tp.trans_type
                        self._send_tpdo(tp)
        return tick

    # ------------------------------------------------------------------ heartbeat
    def _arm_heartbeat(self, *, first: bool) -> None:
        period = self._u(0x1017, 0) * 1e-3
        if period <= 0 or not self._running:
            self._scheduler.cancel("hb")
            return
        self._hb_next = self.clock() + period
        self._scheduler.set("hb", self._hb_next, self._heartbeat_tick)

    def _heartbeat_tick(self) -> None:
        if not self._running or self._state == NmtState.INITIALISING:
            return
        self._send(0x700 + self.node_id, bytes([int(self._state)]))
        period = self._u(0x1017, 0) * 1e-3
        if period <= 0:
            return
        now = self.clock()
        self._hb_next += period
        if self._hb_next <= now:  # fell behind (a stalled process): do not send a burst
            self._hb_next = now + period
        self._scheduler.set("hb", self._hb_next, self._heartbeat_tick)

    def _unsubscribe_heartbeats(self) -> None:
        for cob, cb in self._hb_subs:
            try:
                self.network.unsubscribe(cob, cb)
            except (KeyError, ValueError):
                pass
        self._hb_subs = []
        self._scheduler.cancel_prefix("hbc")

    def _reconfigure_heartbeat_consumers(self, *, restart: bool = False) -> None:
        """Watch the nodes 0x1016 names. An entry whose node and time did not change keeps its
        monitoring (status, deadline); a node no longer watched (or watched anew, or every node when
        ``restart``: a reset) starts from "unknown", and its heartbeat error leaves 0x1001/0x8130."""
        old, old_status, old_state = self._consumers, self._peer_status, self._peer_state
        self._unsubscribe_heartbeats()
        self._consumers = {}
        for s in sorted(self.store.get(0x1016, {})):
            if s == 0:
                continue
            entry = self._u(0x1016, s)
            node_id, ms = (entry >> 16) & 0xFF, entry & 0xFFFF
            if node_id and ms and node_id != self.node_id:
                self._consumers[node_id] = ms * 1e-3
        kept = set() if restart else {n for n, t in self._consumers.items() if old.get(n) == t}
        self._peer_status = {n: old_status[n] if n in kept else "unknown" for n in self._consumers}
        self._peer_state = {n: old_state[n] if n in kept else None for n in self._consumers}
        for n in self._consumers:
            cb = functools.partial(self._on_heartbeat_frame, n)
            self.network.subscribe(0x700 + n, cb)
            self._hb_subs.append((0x700 + n, cb))
            if n in kept and self._peer_status[n] == "alive":
                self._scheduler.set(f"hbc{n}", self._peer_seen.get(n, self.clock()) + self._consumers[n],
                                    functools.partial(self._on_heartbeat_timeout, n))
        for n in old:
            if n not in kept and self._emcy.holds(emcy_mod.EMCY_HEARTBEAT, _hb_source(n)):
                self.clear_emcy(emcy_mod.EMCY_HEARTBEAT, source=_hb_source(n))
        self._set_peer_alive()

    def _on_heartbeat_frame(self, peer: int, can_id: int, data: bytes, timestamp: float) -> None:
        if self._extended:
            return  # a 29-bit ID is no service of ours (counted as unknown)
        if len(data) != 1:
            self.stats.malformed_frames += 1
            return
        state = data[0] & 0x7F
        events = []
        with self._lock:
            timeout = self._consumers.get(peer)
            if not self._running or self._state == NmtState.INITIALISING or timeout is None:
                return
            prev = self._peer_status.get(peer, "unknown")
            prev_state = self._peer_state.get(peer)
            self._peer_status[peer] = "alive"
            self._peer_state[peer] = state
            self._peer_seen[peer] = now = self.clock()
            self._scheduler.set(f"hbc{peer}", now + timeout,
                                functools.partial(self._on_heartbeat_timeout, peer))
            if prev == "lost":
                events.append(PeerEvent(peer, "back", state))
                # this peer's heartbeat error only: 0x8130 stays while another watched node is lost or
                # the application holds it (a latched peer_lost trip)
                self.clear_emcy(emcy_mod.EMCY_HEARTBEAT, source=_hb_source(peer))
            elif prev == "unknown":
                events.append(PeerEvent(peer, "seen", state))
            elif state != prev_state and state != 0 and prev_state not in (None, 0):
                # news only: the boot-up's own PRE-OPERATIONAL heartbeat is part of the boot-up
                events.append(PeerEvent(peer, "state", state))
            if state == 0:
                events.append(PeerEvent(peer, "bootup", state))
            if prev != "alive":
                self._set_peer_alive()
        for ev in events:
            self._call(self._peer_listeners, ev)

    def _on_heartbeat_timeout(self, peer: int) -> None:
        with self._lock:
            if not self._running or self._peer_status.get(peer) != "alive":
                return
            if self.clock() - self._peer_seen.get(peer, -1e18) < self._consumers.get(peer, 0.0):
                return  # a heartbeat came while this job was due: it re-armed the deadline
            self._peer_status[peer] = "lost"
            self.stats.peer_losses += 1
            self._set_peer_alive()
            self.raise_emcy(emcy_mod.EMCY_HEARTBEAT, data=bytes([peer]), source=_hb_source(peer))
        self._call(self._peer_listeners, PeerEvent(peer, "lost", None))

    def _set_peer_alive(self) -> None:
        if PEER_ALIVE_INDEX in self.store:
            alive = bool(self._peer_status) and all(s == "alive" for s in self._peer_status.values())
            self.store[PEER_ALIVE_INDEX][0] = b"\x01" if alive else b"\x00"

    def peer_status(self, node_id: int) -> str:
        """"unknown" (no heartbeat yet), "alive" or "lost" for a consumed peer."""
        return self._peer_status[node_id]

    def peer_state(self, node_id: int) -> int | None:
        """Last NMT state code the peer reported in its heartbeat (None before the first)."""
        return self._peer_state[node_id]

    # ------------------------------------------------------------------ EMCY
    def raise_emcy(self, code: int, *, data: bytes = b"", info16: int = 0, source: str = emcy_mod.APP) -> None:
        """Record error ``code`` (0x1001, 0x1003) and send its EMCY (inhibit time permitting).

        ``source`` tells who holds the error (the program: the default; the device's heartbeat consumer
        and PDO-length check use their own): a code held by another source already is the same error
        still present, so no second frame or history entry (see :mod:`.emcy`)."""
        with self._lock:
            new = self._emcy.raise_error(code, info16, source=source)
            self._store_emcy()
            if new:
                self._queue_emcy(code, self._emcy.register, data)

    def clear_emcy(self, code: int, *, source: str = emcy_mod.APP) -> None:
        """``source`` no longer has error ``code``; the code stays active while another source holds
        it; when no error is left, send the error-reset EMCY (0x0000)."""
        with self._lock:
            if self._emcy.clear(code, source=source):
                self._store_emcy()
                self._queue_emcy(0x0000, self._emcy.register, b"")
            else:
                self._store_emcy()

    def reset_emcy(self) -> None:
        """Clear every active error and send the error-reset EMCY (history 0x1003 is kept)."""
        with self._lock:
            if self._emcy.clear_all():
                self._store_emcy()
                self._queue_emcy(0x0000, 0, b"")

    @property
    def active_errors(self) -> tuple[int, ...]:
        return tuple(self._emcy.active)

    def _store_emcy(self) -> None:
        self.store[0x1001][0] = bytes([self._emcy.register])
        hist = list(self._emcy.history)
        self.store[0x1003][0] = bytes([len(hist)])
        for s in range(1, 9):
            if s in self.store[0x1003]:
                self.store[0x1003][s] = (hist[s - 1] if s <= len(hist) else 0).to_bytes(4, "little")

    def _queue_emcy(self, code: int, register: int, data: bytes) -> None:
        if self._state not in (NmtState.PRE_OPERATIONAL, NmtState.OPERATIONAL):
            self.stats.emcy_suppressed += 1
            return
        inhibit = self._u(0x1015, 0) * 1e-4 if 0x1015 in self.store else 0.0
        now = self.clock()
        if self._emcy_queue or now < self._emcy_last + inhibit:
            if all(c != code for c, _, _ in self._emcy_queue):
                self._emcy_queue.append((code, register, data))
            self._scheduler.set("emcy", max(now, self._emcy_last + inhibit), self._flush_emcy)
            return
        self._send_emcy(code, register, data, now)

    def _send_emcy(self, code: int, register: int, data: bytes, now: float) -> None:
        cob = self._u(0x1014, 0)
        if cob & pdo_mod.PDO_INVALID:
            return
        self._emcy_last = now
        self._send(cob & 0x7FF, emcy_mod.frame(code, register, data))
        self.stats.emcy_sent += 1

    def _flush_emcy(self) -> None:
        with self._lock:
            if not self._emcy_queue:
                return
            if self._state not in (NmtState.PRE_OPERATIONAL, NmtState.OPERATIONAL):
                self.stats.emcy_suppressed += len(self._emcy_queue)
                self._emcy_queue.clear()
                return
            code, register, data = self._emcy_queue.pop(0)
            now = self.clock()
            self._send_emcy(code, register, data, now)
            if self._emcy_queue:
                inhibit = self._u(0x1015, 0) * 1e-4
                self._scheduler.set("emcy", now + inhibit, self._flush_emcy)

    # ------------------------------------------------------------------ sending
    def _send(self, cob_id: int, data: bytes) -> None:
        try:
            self.network.send_message(cob_id, data)
        except (can.CanError, RuntimeError, OSError) as exc:
            self.stats.send_errors += 1
            logger.warning("node %d: send 0x%03X failed: %s", self.node_id, cob_id, exc)

    def send_heartbeat_now(self) -> None:
        """One heartbeat with the current state at once (e.g. the last one before a clean stop)."""
        self._send(0x700 + self.node_id, bytes([int(self._state)]))

