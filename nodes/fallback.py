"""A SYNC consumer without SYNC: when the SYNC producer is gone (its heartbeat lost, or this node's bus), the node runs its
cycles on a local timer (peer lost: the envelope ramps to neutral, then cuts) until SYNC or the peer's
heartbeat come back. Fallback cycles are recorded with ``sync_cycle`` -1.
"""
from __future__ import annotations

import logging
import threading
import time
from typing import TYPE_CHECKING

from telethermo.device.device import NmtState, SyncTick

from telethermo.nodes.schedule import RealtimeTicker

if TYPE_CHECKING:
    from telethermo.nodes.runtime import NodeRuntime

log = logging.getLogger("telethermo.node")


class FallbackCycles:
    """The local timer thread (one at a time)."""

    def __init__(self, rt: "NodeRuntime") -> None:
        self.rt = rt
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        """Start the local cycles unless they run already or the node is not OPERATIONAL."""
        if (self._thread is not None and self._thread.is_alive()) or self.rt.device.state is not NmtState.OPERATIONAL:
            return
        self._thread = threading.Thread(target=self._loop, name="sync-fallback", daemon=True)
        self._thread.start()

    def _loop(self) -> None:
        rt = self.rt
        dev = rt.device
        period = rt.parts.period_s
        ticker = RealtimeTicker(period)
        log.warning("no SYNC producer: local fallback cycles every %g ms", period * 1e3)
        n = 0
        while not rt.stop_event.is_set() and (dev.peer_status(rt.peer_id) == "lost" or rt.bus_outage.down):
            ticker.wait_next()
            if time.monotonic() - rt.cycle.last_sync_at < 2 * period:
                continue  # SYNC still arrives (only the heartbeat is missing)
            with dev.lock:
                if rt.stop_event.is_set() or dev.state is not NmtState.OPERATIONAL or rt.cycle.state is None:
                    continue
                try:
                    rt.cycle.run(SyncTick(None, (), True), fallback=True)
                    n += 1
                except Exception:
                    rt.stats.cycle_errors += 1
                    log.exception("fallback cycle failed: current set to 0 A")
                    rt.safe_current()
        rt.stats.fallback_cycles += n
        log.warning("local fallback cycles ended after %d cycles", n)
