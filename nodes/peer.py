"""The link to the peer node: its latest RPDO1 values and whether it is alive, as the control core
sees them each cycle (:class:`telethermo.control.types.PeerValues`).

The peer is *lost* when the heartbeat consumer (0x1016) reports a timeout, or when its TPDO1 has
been missing for more than ``max_missed_cycles`` consecutive cycles, or at once when this node's own bus
is lost (:meth:`PeerLink.on_bus_down`); it is back when its heartbeat
is seen again and a fresh PDO arrives (the rule: :func:`telethermo.control.peer_policy.peer_alive`).
Thread-safe: the bus's receive thread writes, the cycle reads.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass

from telethermo.control.peer_policy import peer_alive
from telethermo.control.types import PeerValues


@dataclass
class PeerCounters:
    """What the link counted (exposed in the log and the node's status)."""

    pdos: int = 0
    missed_cycles: int = 0
    losses: int = 0
    returns: int = 0
    non_finite: int = 0


class PeerLink:
    """Latest peer values + link state.

    Args:
        max_missed_cycles: consecutive cycles without a fresh PDO after which the peer counts as
            lost (even if its heartbeat still comes).
    """

    def __init__(self, max_missed_cycles: int = 10) -> None:
        if max_missed_cycles < 1:
            raise ValueError(f"max_missed_cycles {max_missed_cycles}: expected >= 1")
        self.max_missed_cycles = max_missed_cycles
        self._lock = threading.Lock()
        self._estimate_C = math.nan
        self._flux_W = math.nan
        self._ever = False
        self._fresh = False
        self._missed = 0
        self._hb_ok = True
        self._bus_ok = True
        self._alive_reported: bool | None = None  # None until the first PDO
        self._contact: bool | None = None  # the peer's contact flag (RPDO2); None until it arrives
        self.counters = PeerCounters()

    def on_pdo(self, estimate_C: float, flux_W: float) -> None:
        """The peer's TPDO1 arrived (values as decoded from REAL32: may be NaN, the core copes)."""
        with self._lock:
            self._estimate_C, self._flux_W = estimate_C, flux_W
            self._ever = True
            self._fresh = True
            self.counters.pdos += 1
            if not (math.isfinite(estimate_C) and math.isfinite(flux_W)):
                self.counters.non_finite += 1

    def on_contact(self, contact: bool) -> None:
        """The peer's contact PDO (RPDO2) arrived."""
        with self._lock:
            self._contact = bool(contact)

    def start_with(self, values: PeerValues) -> None:
        """Stand-in values until the peer's first PDO (``initial_peer`` of the first sample): not
        fresh, so a peer whose PDOs never come is declared lost after ``max_missed_cycles``."""
        with self._lock:
            if not self._ever:
                self._estimate_C, self._flux_W = values.estimate_C, values.flux_W
                self._ever = True
                self._fresh = False
                self._missed = -1  # the first take() (cycle 0) is not a miss

    def on_heartbeat_timeout(self) -> None:
        with self._lock:
            self._hb_ok = False

    def on_heartbeat(self) -> None:
        """A heartbeat of the peer was seen (any NMT state)."""
        with self._lock:
            self._hb_ok = True

    def on_bus_down(self) -> None:
        """This node's bus is gone (telethermo.transport.resilient): the peer is lost at once, not only after
        the heartbeat consumer time."""
        with self._lock:
            self._bus_ok = False

    def on_bus_up(self) -> None:
        """The bus is back; the peer is alive again when its heartbeat and fresh PDOs say so."""
        with self._lock:
            self._bus_ok = True

    @property
    def bus_ok(self) -> bool:
        with self._lock:
            return self._bus_ok

    @property
    def alive(self) -> bool:
        with self._lock:
            return self._alive_locked()

    def _alive_locked(self) -> bool:
        return peer_alive(
            heartbeat_ok=self._hb_ok and self._bus_ok,
            seen=self._ever,
            missed_cycles=self._missed,
            max_missed_cycles=self.max_missed_cycles,
        )

    def take(self, material: tuple[int, float, int, float] | None = None) -> PeerValues | None:
        """The values for this cycle (None before the first PDO or :meth:`start_with`); marks them consumed.
        ``material``: the slave's identification as its PDOs last brought it (code, beta, touches,
        T_object0 °C), carried in the same PeerValues (one object per cycle, no copy)."""
        with self._lock:
            if self._fresh:
                self._missed = 0
            elif self._ever:
                self._missed += 1
                if self._missed > 0:
                    self.counters.missed_cycles += 1
            if not self._ever:
                return None
            alive = self._alive_locked()
            if self._alive_reported is not None and alive != self._alive_reported:
                if alive:
                    self.counters.returns += 1
                else:
                    self.counters.losses += 1
            self._alive_reported = alive
            fresh, self._fresh = self._fresh, False
            return PeerValues(self._estimate_C, self._flux_W, fresh, alive, self._contact, *(material or ()))
