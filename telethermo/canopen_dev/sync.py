"""SYNC producer with counter (0x1005 bit 30, 0x1006, 0x1019) that also ticks its own device.

A node never receives its own frames, so :meth:`SyncProducer.transmit` sends the SYNC and then runs
the producing device's own SYNC processing (RPDO commit, SYNC handlers, TPDOs) in the caller's
thread. Two ways to drive it:

- lockstep: call :meth:`transmit` yourself, e.g. after the peer's PDO of the previous cycle arrived
  (:meth:`telethermo.canopen_dev.device.Device.wait_rpdo`);
- real time: :meth:`start` runs a thread that sends SYNC every ``period_s`` on an absolute
  schedule and counts late cycles (a SYNC sent more than ``late_tolerance_s`` after its slot;
  slots missed entirely are counted too and skipped, never sent in a burst).
"""
from __future__ import annotations

import logging
import threading
import time
from typing import Callable

from telethermo.canopen_dev.device import Device, NmtState, SyncTick

logger = logging.getLogger(__name__)


class SyncProducer:
    """SYNC producer of ``device`` (which must have 0x1005 bit 30 set)."""

    def __init__(self, device: Device, *, clock: Callable[[], float] = time.monotonic):
        self.device = device
        self.clock = clock
        self.counter = 0          # last counter sent (0: none yet)
        self.sent = 0
        self.late_cycles = 0
        self.max_lateness_s = 0.0
        self.errors = 0
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        device.add_nmt_listener(self._on_nmt)

    def _on_nmt(self, old: NmtState, new: NmtState, command: int | None) -> None:
        if new is NmtState.PRE_OPERATIONAL and old is NmtState.INITIALISING:
            self.counter = 0  # CiA 301: the counter restarts at 1 after a reset

    def transmit(self) -> SyncTick | None:
        """Send one SYNC (with the next counter value if 0x1019 > 0) and tick the own device.

        Returns the own device's SyncTick, or None without sending anything in STOPPED (CiA 301: a
        stopped node produces no SYNC; an NMT start resumes it, and the counter goes on). Raises
        RuntimeError if this device is not the SYNC producer or is not powered on (INITIALISING:
        before ``start()`` or after ``close()``).

        The device lock is held from sending SYNC k until the own SYNC k is processed: a peer that
        answers SYNC k faster than this thread reaches its own tick would otherwise have its TPDO k
        committed as an RPDO of SYNC k (one cycle early) instead of SYNC k+1. With the lock held, the
        receive thread waits and stores that PDO as pending for the next SYNC.
        """
        dev = self.device
        with dev.lock:
            if not dev.is_sync_producer:
                raise RuntimeError(f"node {dev.node_id} is not the SYNC producer (0x1005 bit 30 is clear)")
            if dev.state is NmtState.STOPPED:
                return None   # NMT STOP from any master: no SYNC, and nothing to raise into a SYNC loop
            if dev.state not in (NmtState.PRE_OPERATIONAL, NmtState.OPERATIONAL):
                raise RuntimeError(f"node {dev.node_id} may not produce SYNC in {dev.state.name}")
            overflow = dev.core.u(0x1019, 0)
            if overflow:
                self.counter = self.counter + 1 if 0 < self.counter < overflow else 1
                counter: int | None = self.counter
                dev.core.send(dev.sync_cob_id, bytes((counter,)))
            else:
                counter = None
                dev.core.send(dev.sync_cob_id, b"")
            self.sent += 1
            return dev.process_sync(counter)

    # ---------------------------------------------------------------- real time
    def start(self, period_s: float | None = None, *, late_tolerance_s: float | None = None) -> None:
        """Send SYNC every ``period_s`` (default 0x1006) from a thread until :meth:`stop`."""
        if self._thread is not None:
            raise RuntimeError("SYNC producer already running")
        period = period_s if period_s is not None else self.device.core.u(0x1006, 0) * 1e-6
        if not period or period <= 0:
            raise ValueError("a SYNC period > 0 is needed (argument or 0x1006)")
        tolerance = period / 2 if late_tolerance_s is None else late_tolerance_s
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, args=(period, tolerance),
                                        name=f"sync-producer-{self.device.node_id}", daemon=True)
        self._thread.start()

    def stop(self, timeout: float = 2.0) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout)
            self._thread = None

    def _run(self, period: float, tolerance: float) -> None:
        slot = self.clock() + period
        while not self._stop.is_set():
            delay = slot - self.clock()
            if delay > 0 and self._stop.wait(delay):
                return
            lateness = self.clock() - slot
            self.max_lateness_s = max(self.max_lateness_s, lateness)
            if lateness > tolerance:
                self.late_cycles += 1
            try:
                self.transmit()
            except Exception:
                self.errors += 1
                logger.exception("SYNC transmit failed")
            slot += period
            behind = self.clock() - slot
            if behind > period:  # whole slots missed: count them, do not send a burst
                missed = int(behind // period)
                self.late_cycles += missed
                slot += missed * period
