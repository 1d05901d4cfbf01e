"""Heartbeat producer (0x1017, on every NMT path) and heartbeat consumer (0x1016) with timeout (EMCY
0x8130, held per watched node) and "seen" / "lost" / "back" / "bootup" / "state" peer events."""

from __future__ import annotations

import functools
from typing import Callable

from canopen import SdoAbortedError

from telethermo.cia301 import ABORT_INCOMPATIBLE, EMCY_HEARTBEAT
from telethermo.device.context import DeviceCore, FrameCallback, NmtState
from telethermo.device.emcy_producer import EmcyProducer
from telethermo.device.events import PeerEvent

#: 1 while every consumed peer is alive (manufacturer object, see bus_config/edsgen.py)
PEER_ALIVE_INDEX = 0x2705


def hb_source(node_id: int) -> str:
    """The EMCY source of the heartbeat consumer's error for one watched node."""
    return f"heartbeat{node_id}"


class Heartbeat:
    """The heartbeat producer and consumer of one device."""

    def __init__(self, core: DeviceCore, emcy: EmcyProducer):
        self.core = core
        self.emcy = emcy
        self.listeners: list[Callable[[PeerEvent], None]] = []
        self.consumers: dict[int, float] = {}  # peer node-ID -> timeout s
        self._status: dict[int, str] = {}  # "unknown" / "alive" / "lost"
        self._state: dict[int, int | None] = {}
        self._seen: dict[int, float] = {}
        self._subs: list[tuple[int, FrameCallback]] = []
        self._next = 0.0

    # ------------------------------------------------------------------ producer
    def arm(self) -> None:
        """(Re)start the producer at 0x1017's period (0: none)."""
        core = self.core
        period = core.u(0x1017, 0) * 1e-3
        if period <= 0 or not core.running:
            core.scheduler.cancel("hb")
            return
        self._next = core.clock() + period
        core.scheduler.set("hb", self._next, self._tick)

    def cancel(self) -> None:
        self.core.scheduler.cancel("hb")

    def producer_written(self, index: int, sub: int, value: int, old: bytes | None) -> None:
        self.arm()

    def send_now(self) -> None:
        """One heartbeat with the current state at once."""
        self.core.send(0x700 + self.core.node_id, bytes([int(self.core.state)]))

    def _tick(self) -> None:
        core = self.core
        if not core.running or core.state == NmtState.INITIALISING:
            return
        self.send_now()
        period = core.u(0x1017, 0) * 1e-3
        if period <= 0:
            return
        now = core.clock()
        self._next += period
        if self._next <= now:  # fell behind (a stalled process): do not send a burst
            self._next = now + period
        core.scheduler.set("hb", self._next, self._tick)

    # ------------------------------------------------------------------ consumer
    def status(self, node_id: int) -> str:
        """ "unknown" (no heartbeat yet), "alive" or "lost" for a consumed peer."""
        return self._status[node_id]

    def peer_state(self, node_id: int) -> int | None:
        """Last NMT state code the peer reported in its heartbeat (None before the first)."""
        return self._state[node_id]

    def unsubscribe(self) -> None:
        for cob, cb in self._subs:
            self.core.unsubscribe(cob, cb)
        self._subs = []
        self.core.scheduler.cancel_prefix("hbc")

    def consumers_written(self, index: int, sub: int, value: int, old: bytes | None) -> None:
        """SDO write to 0x1016: two entries watching one node are refused (0x06040043)."""
        core = self.core
        entries = [core.u(0x1016, s) for s in core.store[0x1016] if s > 0]
        ids = [(e >> 16) & 0xFF for e in entries if (e >> 16) & 0xFF and e & 0xFFFF]
        if len(ids) != len(set(ids)):
            raise SdoAbortedError(ABORT_INCOMPATIBLE)
        self.reconfigure()

    def reconfigure(self, *, restart: bool = False) -> None:
        """Watch the nodes 0x1016 names. An entry whose node and time did not change keeps its
        monitoring (status, deadline); a node no longer watched (or watched anew, or every node when
        ``restart``: a reset) starts from "unknown", and its heartbeat error leaves 0x1001/0x8130."""
        core = self.core
        old, old_status, old_state = self.consumers, self._status, self._state
        self.unsubscribe()
        self.consumers = {}
        for s in sorted(core.store.get(0x1016, {})):
            if s == 0:
                continue
            entry = core.u(0x1016, s)
            node_id, ms = (entry >> 16) & 0xFF, entry & 0xFFFF
            if node_id and ms and node_id != core.node_id:
                self.consumers[node_id] = ms * 1e-3
        kept = set() if restart else {n for n, t in self.consumers.items() if old.get(n) == t}
        self._status = {n: old_status[n] if n in kept else "unknown" for n in self.consumers}
        self._state = {n: old_state[n] if n in kept else None for n in self.consumers}
        for n in self.consumers:
            self._subs.append(core.subscribe(0x700 + n, functools.partial(self._on_frame, n)))
            if n in kept and self._status[n] == "alive":
                core.scheduler.set(
                    f"hbc{n}",
                    self._seen.get(n, core.clock()) + self.consumers[n],
                    functools.partial(self._on_timeout, n),
                )
        for n in old:
            if n not in kept and self.emcy.holds(EMCY_HEARTBEAT, hb_source(n)):
                self.emcy.clear(EMCY_HEARTBEAT, source=hb_source(n))
        self._store_peer_alive()

    def _on_frame(self, peer: int, can_id: int, data: bytes | bytearray, timestamp: float) -> None:
        core = self.core
        if core.extended:
            return  # a 29-bit ID is no service of ours (counted as unknown)
        if len(data) != 1:
            core.stats.malformed_frames += 1
            return
        state = data[0] & 0x7F
        with core.lock:
            timeout = self.consumers.get(peer)
            if not core.running or core.state == NmtState.INITIALISING or timeout is None:
                return
            events = self._heard(peer, state, timeout)
        for ev in events:
            core.call(self.listeners, ev)

    def _heard(self, peer: int, state: int, timeout: float) -> list[PeerEvent]:
        """Bookkeeping of one heartbeat of ``peer`` (device lock held); the events it makes."""
        core = self.core
        events = []
        prev = self._status.get(peer, "unknown")
        prev_state = self._state.get(peer)
        self._status[peer] = "alive"
        self._state[peer] = state
        self._seen[peer] = now = core.clock()
        core.scheduler.set(f"hbc{peer}", now + timeout, functools.partial(self._on_timeout, peer))
        if prev == "lost":
            events.append(PeerEvent(peer, "back", state))
            # this peer's heartbeat error only: 0x8130 stays while another watched node is lost or
            # the application holds it (a latched peer_lost trip)
            self.emcy.clear(EMCY_HEARTBEAT, source=hb_source(peer))
        elif prev == "unknown":
            events.append(PeerEvent(peer, "seen", state))
        elif state != prev_state and state != 0 and prev_state not in (None, 0):
            # news only: the boot-up's own PRE-OPERATIONAL heartbeat is part of the boot-up
            events.append(PeerEvent(peer, "state", state))
        if state == 0:
            events.append(PeerEvent(peer, "bootup", state))
        if prev != "alive":
            self._store_peer_alive()
        return events

    def _on_timeout(self, peer: int) -> None:
        core = self.core
        with core.lock:
            if not core.running or self._status.get(peer) != "alive":
                return
            if core.clock() - self._seen.get(peer, -1e18) < self.consumers.get(peer, 0.0):
                return  # a heartbeat came while this job was due: it re-armed the deadline
            self._status[peer] = "lost"
            core.stats.peer_losses += 1
            self._store_peer_alive()
            self.emcy.raise_error(EMCY_HEARTBEAT, data=bytes([peer]), source=hb_source(peer), subject=peer)
        core.call(self.listeners, PeerEvent(peer, "lost", None))

    def _store_peer_alive(self) -> None:
        store = self.core.store
        if PEER_ALIVE_INDEX in store:
            alive = bool(self._status) and all(s == "alive" for s in self._status.values())
            store[PEER_ALIVE_INDEX][0] = b"\x01" if alive else b"\x00"
