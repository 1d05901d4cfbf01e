"""What a node does when its own bus goes away and comes back (issue 12; the bus:
:class:`telethermo.transport.resilient.ResilientBus`).

- **Bus lost** (hub killed, socketcand disconnect, interface down, bus-off): the peer counts as lost at
  once (:meth:`nodes.peer.PeerLink.on_bus_down`), so the next control cycle trips ``peer_lost``: the
  envelope ramps to neutral and cuts, as for a peer whose heartbeat stopped. The SYNC producer keeps
  running its own cycles (its SYNCs are dropped, counted by the bus); a SYNC consumer gets no SYNC and
  starts its local fallback cycles at once. One log line.
- **Bus back**: the bus reopened by itself; until the peer's first heartbeat after that
  (:attr:`BusOutage.awaiting_peer`) the peer may still be without its bus (the two nodes reopen at
  different times), so the SYNC producer owes it nothing for the SYNCs it sends meanwhile (a SYNC the
  peer never saw would otherwise be waited for in lockstep forever); one log line and EMCY 0x8140 ("recovered
  from bus off", CiA 301), whose error is cleared at once (0x1003 keeps it; the error-reset EMCY follows when
  no other error, e.g. the peer trip's 0x8130, is active). The peer is alive again when its heartbeat and
  fresh PDOs are seen; then the peer trips are cleared as for any peer return
  (telethermo.control.peer_policy).
"""

from __future__ import annotations

import logging
import threading
from typing import Callable

from telethermo.cia301 import EMCY_BUS_OFF_RECOVERED
from telethermo.device.device import Device

from telethermo.nodes.peer import PeerLink

log = logging.getLogger("telethermo.node")

#: the EMCY bookkeeping's source name for the bus's own errors
EMCY_SOURCE = "bus"


class BusOutage:
    """The node's bus state as its reopening bus reports it (``on_change`` is that bus's callback).

    ``peer`` gives the node's peer link (a new one at each power-on), ``start_fallback`` starts the local
    cycles of a SYNC consumer (None on the SYNC producer); the device comes by :meth:`bind`."""

    def __init__(
        self, *, peer: Callable[[], PeerLink], peer_id: int, start_fallback: Callable[[], None] | None
    ) -> None:
        self._peer = peer
        self._peer_id = peer_id
        self._start_fallback = start_fallback
        self._dev: Device | None = None
        self.down = False
        self.awaiting_peer = False
        """The bus is back but no heartbeat of the peer was seen since: it may not hear us yet."""
        self.outages = 0
        self.returns = 0
        self._lock = threading.Lock()

    def bind(self, dev: Device) -> None:
        """The device, once it exists (the bus reports changes before it does)."""
        self._dev = dev

    @property
    def peer_unreachable(self) -> bool:
        """The bus is down, or back without a heartbeat of the peer yet."""
        return self.down or self.awaiting_peer

    def on_peer_heartbeat(self, can_id: int, data: bytes, timestamp: float) -> None:
        """A heartbeat frame of the peer (subscribed by the runtime): the peer hears the bus again."""
        self.awaiting_peer = False

    def on_change(self, up: bool, reason: str) -> None:
        """The bus went down (``up`` False) or is back; runs in the thread that noticed (quick,
        never raises)."""
        with self._lock:
            if up == (not self.down):
                return
            self.down = not up
            if up:
                self.returns += 1
            else:
                self.outages += 1
            self.awaiting_peer = True
        if not up:
            self._peer().on_bus_down()
            log.warning(
                "bus lost (%s): peer %d counts as lost; the envelope goes safe; retrying",
                reason,
                self._peer_id,
            )
            if self._start_fallback is not None and self._dev is not None:
                self._start_fallback()
            return
        self._peer().on_bus_up()
        log.warning("bus back (%s): waiting for peer %d's heartbeat and PDOs", reason, self._peer_id)
        dev = self._dev
        if dev is not None:
            dev.emcy.raise_error(EMCY_BUS_OFF_RECOVERED, source=EMCY_SOURCE)
            dev.emcy.clear(EMCY_BUS_OFF_RECOVERED, source=EMCY_SOURCE)
