"""A SYNC consumer without SYNC: when the SYNC producer is gone (its heartbeat lost, or this node's bus), the
node runs its cycles on a local timer (peer lost: the envelope ramps to neutral, then cuts) until SYNC or the
peer's heartbeat come back. Fallback cycles are recorded with ``sync_cycle`` -1.
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Callable

from telethermo.device.device import Device, NmtState, SyncTick

from telethermo.nodes.bus_outage import BusOutage
from telethermo.nodes.cycle import ControlCycle
from telethermo.nodes.schedule import RealtimeTicker
from telethermo.nodes.stats import RuntimeStats

log = logging.getLogger("telethermo.node")


class FallbackCycles:
    """The local timer thread (one at a time): ``cycle`` run every ``period_s`` while peer ``peer_id`` is lost
    or the bus is down (``bus_outage``), until ``stop_event``; a failed cycle counts in ``stats`` and calls
    ``safe_current``. The device comes by :meth:`bind`."""

    def __init__(
        self,
        *,
        cycle: ControlCycle,
        bus_outage: BusOutage,
        stats: RuntimeStats,
        stop_event: threading.Event,
        safe_current: Callable[[], None],
        period_s: float,
        peer_id: int,
    ) -> None:
        self._cycle = cycle
        self._bus_outage = bus_outage
        self._stats = stats
        self._stop_event = stop_event
        self._safe_current = safe_current
        self._period_s = period_s
        self._peer_id = peer_id
        self._dev: Device | None = None
        self._thread: threading.Thread | None = None

    def bind(self, dev: Device) -> None:
        self._dev = dev

    def start(self) -> None:
        """Start the local cycles unless they run already or the node is not OPERATIONAL."""
        dev = self._dev
        assert dev is not None, "start() before bind()"
        if (self._thread is not None and self._thread.is_alive()) or dev.state is not NmtState.OPERATIONAL:
            return
        self._thread = threading.Thread(target=self._loop, name="sync-fallback", daemon=True)
        self._thread.start()

    def _loop(self) -> None:
        dev, cycle, stop = self._dev, self._cycle, self._stop_event
        assert dev is not None
        period = self._period_s
        ticker = RealtimeTicker(period)
        log.warning("no SYNC producer: local fallback cycles every %g ms", period * 1e3)
        n = 0
        while not stop.is_set() and (dev.peer_status(self._peer_id) == "lost" or self._bus_outage.down):
            ticker.wait_next()
            if time.monotonic() - cycle.last_sync_at < 2 * period:
                continue  # SYNC still arrives (only the heartbeat is missing)
            with dev.lock:
                if stop.is_set() or dev.state is not NmtState.OPERATIONAL or cycle.state is None:
                    continue
                try:
                    cycle.run(SyncTick(None, (), True), fallback=True)
                    n += 1
                except Exception:
                    self._stats.cycle_errors += 1
                    log.exception("fallback cycle failed: current set to 0 A")
                    self._safe_current()
        self._stats.fallback_cycles += n
        log.warning("local fallback cycles ended after %d cycles", n)
