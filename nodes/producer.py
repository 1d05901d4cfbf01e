"""The SYNC producer of the pair (the master by default): the one SYNC scheduler of telethermo.

It is the NMT master of the pair (it starts every node, and each one that reports a boot-up or a
pre-operational heartbeat, see the node runtime's peer events; the decisions are :mod:`nodes.nmt_policy`'s,
carried out here and in the runtime) and runs the schedule
(DESIGN.md §3):

- **lockstep**: SYNC k+1 only after the peer's PDOs of cycle k, or after a timeout when the peer is
  silent. While the heartbeat consumer still sees the peer alive it is merely slow (a loaded machine),
  so the producer keeps waiting, up to a patience bound for a peer whose heartbeat runs but whose
  cycle hangs. A PDO that comes after its wait timed out is still owed: the next cycle waits for both,
  so a slow peer falls back into step instead of staying one PDO behind.
- **real time**: SYNC at the wall clock's period (:class:`nodes.schedule.RealtimeTicker`); late cycles
  counted in 0x2703 and the log (one summary line per second at most).

CiA 301: the SYNC producer produces in PRE-OPERATIONAL too (paced by the period; the SYNC handlers
see ``tick.operational`` False, no PDO goes out); in STOPPED it does not.
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Callable, Protocol

from telethermo.device.device import Device, NmtState
from telethermo.device.netconfig import NetworkConfig
from telethermo.device.sync import SyncProducer

from telethermo.nodes.bus_outage import BusOutage
from telethermo.nodes.nmt_policy import (
    SESSION_START,
    LockstepWait,
    lockstep_wait,
    peer_is_paused,
    peer_schedule_status,
    session_end_command,
    sync_while_not_operational,
)
from telethermo.nodes.param_slot import ParamSlot
from telethermo.nodes.parts import NodeParts
from telethermo.nodes.schedule import LateCycleLog, RealtimeTicker
from telethermo.nodes.stats import RuntimeStats

log = logging.getLogger("telethermo.node")


class ProducerHost(Protocol):
    """What the SYNC producer reads of its node (the node runtime is one): set at start (``device``,
    ``sync``) or changed by the peer's events (``peer_*``, ``nmt_leaves``) while it runs; ``ticker`` is
    written (the real-time schedule's ticker, None in lockstep)."""

    stop_event: threading.Event
    device: Device | None
    sync: SyncProducer | None
    net: NetworkConfig
    parts: NodeParts
    settings: ParamSlot
    bus_outage: BusOutage
    stats: RuntimeStats
    lockstep: bool
    ticker: RealtimeTicker | None
    peer_id: int
    peer_paused: bool
    """The peer's heartbeat went from OPERATIONAL to STOPPED/PRE-OPERATIONAL."""
    peer_boots: int
    peer_pauses: int
    nmt_leaves: int
    """How often this node left OPERATIONAL."""

    def mark_sync_sent(self) -> None:
        """A SYNC is about to go out (the peer's first TPDO1 after it is timed)."""


def wait_for_peer(rt: ProducerHost, timeout_s: float) -> bool:
    """Wait until the peer's heartbeat is seen (it is started by NMT when it is)."""
    deadline = time.monotonic() + timeout_s
    while not rt.stop_event.is_set() and time.monotonic() < deadline:
        if rt.device.peer_status(rt.peer_id) == "alive":
            return True
        rt.stop_event.wait(0.01)
    return False


def peer_paused(rt: ProducerHost) -> bool:
    """The peer answers no SYNC (:func:`nodes.nmt_policy.peer_is_paused`)."""
    return peer_is_paused(rt.peer_paused, rt.device.peer_state(rt.peer_id))


class _PeerDebt:
    """Lockstep bookkeeping: the PDOs owed by the peer (one per SYNC sent while it was believed alive).

    The peer's PDOs of one SYNC are TPDO1 (estimate, flux), then TPDO5 (contact flag), in that order on an
    ordered transport; waiting for the last synchronous RPDO (``last``) means every one of the cycle is in.
    """

    def __init__(self, rt: ProducerHost) -> None:
        self.rt = rt
        dev = rt.device
        self.last = max((n for n, p in dev.rpdos.items() if p.valid and p.trans_type <= 240), default=1)
        self.owed, self.base = 0, dev.rpdo_count(self.last)
        self._marks = self._events()

    def _events(self) -> tuple[int, int, int]:
        return self.rt.peer_boots, self.rt.peer_pauses, self.rt.nmt_leaves

    def refresh(self, status: str) -> None:
        """A peer lost, never seen, paused (``status`` "paused": stopped/pre-operational), rebooted or started
        again owes nothing (the SYNCs it did not answer are never answered); when we left OPERATIONAL its PDOs
        were dropped."""
        if status != "alive" or self._marks != self._events():
            self.owed, self.base, self._marks = 0, self.rt.device.rpdo_count(self.last), self._events()

    def left_operational(self) -> bool:
        """This node left OPERATIONAL since the last refresh."""
        return self._marks[2] != self.rt.nmt_leaves

    def wait(self, k: int, wait_s: float, patience_s: float) -> None:
        """After SYNC k-1 to a live peer: wait for its PDOs, up to ``patience_s`` while it stays alive."""
        rt, dev = self.rt, self.rt.device
        self.owed += 1
        waited, arrived = 0.0, False
        while not arrived and waited < patience_s and not rt.stop_event.is_set():
            arrived = dev.wait_rpdo(self.last, after=self.base + self.owed - 1, timeout=wait_s)
            waited += wait_s
            if not arrived and (
                dev.peer_status(rt.peer_id) != "alive"
                or peer_paused(rt)
                or rt.bus_outage.peer_unreachable
                or self.left_operational()
            ):
                break
        if arrived:
            self.base, self.owed = dev.rpdo_count(self.last), 0
        elif not self.left_operational():  # we were stopped meanwhile: the debt is dropped at the next cycle
            rt.stats.lockstep_timeouts += 1
            log.warning(
                "cycle %d: no PDO of node %d within %g ms (%d owed)",
                k - 1,
                rt.peer_id,
                waited * 1e3,
                self.owed,
            )


def _not_operational(rt: ProducerHost, ticker: RealtimeTicker | None) -> None:
    """Stopped or pre-operational by an NMT command from elsewhere: no control cycles of ours; a SYNC per
    period in PRE-OPERATIONAL."""
    if ticker is not None:
        ticker.wait_next()
    else:
        rt.stop_event.wait(rt.parts.period_s)
    if sync_while_not_operational(rt.device.state) and not rt.stop_event.is_set():
        rt.sync.transmit()


def run_producer(
    rt: ProducerHost,
    cycles: int,
    *,
    progress_every: int = 0,
    progress: Callable[[int, int], None] | None = None,
) -> int:
    """Start all nodes (NMT) and run ``cycles`` SYNC cycles (0 = until stopped); return cycles run."""
    dev, sync = rt.device, rt.sync
    assert dev is not None and sync is not None
    dev.nmt_command(SESSION_START, 0)
    period = rt.parts.period_s
    # how long one lockstep cycle waits for the peer's PDO: half the heartbeat consumer time, so that
    # a merely slow peer is told from a lost one (which the heartbeat consumer reports)
    wait_s = rt.net.heartbeat.consumer_ms * 0.5e-3 or 0.5
    patience_s = 20 * wait_s  # a peer alive by its heartbeat but silent this long: count, go on
    ticker = rt.ticker = None if rt.lockstep else RealtimeTicker(period, tolerance_s=period / 2)
    late_log = LateCycleLog(log)  # a summary line per 10 s at most, not one per late cycle
    debt = _PeerDebt(rt)
    k = 0
    while not rt.stop_event.is_set() and (cycles == 0 or k < cycles):
        if dev.state is not NmtState.OPERATIONAL:
            _not_operational(rt, ticker)
            continue
        if ticker is not None:
            late, lateness = ticker.wait_next()
            if late:
                rt.stats.late_cycles = ticker.stats.late_cycles
            late_log.cycle(k, late, lateness)
        # no bus, or back before the peer's: nobody answers (nodes.bus_outage)
        status = peer_schedule_status(
            dev.peer_status(rt.peer_id),
            unreachable=rt.bus_outage.peer_unreachable,
            paused=rt.peer_paused,
            peer_state=dev.peer_state(rt.peer_id),
        )
        debt.refresh(status)
        rt.mark_sync_sent()
        if (
            sync.transmit() is None
        ):  # holds the device lock until our own SYNC k is processed (no early PDO k)
            continue  # stopped by an NMT command that came while we waited for the slot: no SYNC sent
        k += 1
        if rt.lockstep:
            wait = lockstep_wait(status, rt.settings.mode)
            if wait is LockstepWait.PEER_PDOS:
                debt.wait(k, wait_s, patience_s)
            elif wait is LockstepWait.PERIOD:
                # peer lost, not yet seen or not OPERATIONAL: our envelope keeps running,
                # paced by the SYNC period
                dev.wait_rpdo(debt.last, after=dev.rpdo_count(debt.last), timeout=period)
        if progress is not None and progress_every and (k % progress_every == 0 or k == cycles):
            progress(k, cycles)
    late_log.flush()
    # the session is over: every node leaves OPERATIONAL (no PDOs, current 0) before we go silent,
    # so that the peer does not take our end for a loss
    end = session_end_command(dev.state)
    if end is not None:
        dev.nmt_command(end, 0)
    return k
