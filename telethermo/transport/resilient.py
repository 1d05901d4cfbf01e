"""A python-can bus that outlives the loss of its transport: bus loss and return (issue 12).

A node's bus can go away under it: the hub (a socketcand server) killed or restarted, a socketcand
disconnect, a SocketCAN interface set down (``ip link set can0 down``), a controller in bus-off. python-can
and canopen do not recover from that by themselves (python-can 4.6, canopen 2.4):

- the socketcand client sees the server's end of the TCP stream as "readable, 0 bytes" and returns no
  frame, immediately and forever (its receive loop spins); its sends raise ``BrokenPipeError``;
- a SocketCAN socket raises ``CanOperationError`` (ENETDOWN) once, then stays silent;
- canopen's :class:`canopen.Network` keeps the first exception of its notifier thread, which then ends, and
  re-raises it after *every* later ``send_message``: one receive error silences the node for good.

:class:`ResilientBus` wraps the bus that :func:`telethermo.transport.bus.open_bus` opens and is itself a
python-can bus (give it to ``canopen.Network``). It never raises from ``recv``, so the notifier thread
never dies. An outage is detected by a receive or send error, the socketcand server's end of stream, a
SocketCAN interface whose link is down (``/sys/class/net/<if>/operstate``; bus-off turns the carrier off)
or a bus-off error frame. While the bus is down, frames sent are dropped (counted; a CAN controller in
bus-off sends nothing either) and the bus is probed and reopened with a back-off (0.05 s doubling up to
1 s). ``on_change(up, reason)`` is called once when the bus goes down and once when it is back; it runs in
the thread that noticed (the notifier's, or a sender's) and must be quick and must not raise.
"""

from __future__ import annotations

import logging
import select
import socket
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import can

from telethermo.transport.bus import TransportSettings, open_bus

log = logging.getLogger(__name__)

#: SocketCAN error class "bus-off" in an error frame's identifier (linux/can/error.h CAN_ERR_BUSOFF)
CAN_ERR_BUSOFF = 0x040
#: Reopen back-off: first wait and cap, s
BACKOFF_FIRST_S, BACKOFF_MAX_S = 0.05, 1.0
#: How often a bus that delivers frames is checked for a lost link anyway (SocketCAN operstate), s
HEALTH_EVERY_S = 0.25
#: socketcand probe: TCP connect timeout, s
PROBE_TIMEOUT_S = 0.5

OnChange = Callable[[bool, str], None]


@dataclass
class OutageStats:
    """What the bus counted: outages, reopen attempts and frames dropped while down."""

    outages: int = 0
    reopens: int = 0
    attempts: int = 0
    frames_dropped: int = 0
    down_s: float = 0.0
    """Total time the bus was down, s (outages that ended)."""
    last_reason: str = ""


def link_down_reason(settings: TransportSettings, sysfs: Path = Path("/sys/class/net")) -> str | None:
    """Why the transport cannot carry frames now (None: it can, as far as can be told without opening it).

    socketcand: the server does not accept a TCP connection; socketcan: the interface is missing, not up, or
    its carrier is off (bus-off); other interfaces: never (their errors show on use)."""
    if settings.interface == "socketcand":
        try:
            socket.create_connection((settings.host, settings.port), timeout=PROBE_TIMEOUT_S).close()
        except OSError as exc:
            return f"socketcand server {settings.host}:{settings.port}: {exc.strerror or exc}"
        return None
    if settings.interface == "socketcan":
        base = sysfs / settings.channel
        try:
            flags = int((base / "flags").read_text(), 16)
            oper = (base / "operstate").read_text().strip()
        except (OSError, ValueError):
            return f"interface {settings.channel} does not exist"
        if not flags & 0x1:
            return f"interface {settings.channel} is down"
        if oper not in ("up", "unknown"):  # vcan says "unknown" when up; bus-off: carrier off, "down"
            return f"interface {settings.channel}: link {oper} (going down, or bus-off)"
    return None


def _first_line(exc: BaseException) -> str:
    """An exception as one line (python-can puts a whole traceback into some messages, after two spaces on
    the first line: 'Failed to receive: [Errno 104] ...  Traceback (most recent call last):')."""
    text = str(exc).strip().split("Traceback (most recent call last)", 1)[0].strip()
    return text.splitlines()[0].strip() if text else type(exc).__name__


def _server_closed(bus: can.BusABC) -> bool:
    """A socketcand client whose server closed the TCP stream (readable with 0 bytes to read)."""
    sock = getattr(bus, "_SocketCanDaemonBus__socket", None)  # python-can keeps it private
    if sock is None:
        return False
    try:
        readable, _, _ = select.select([sock], [], [], 0)
        return bool(readable) and sock.recv(1, socket.MSG_PEEK) == b""
    except OSError:
        return True


class ResilientBus(can.BusABC):
    """The bus ``settings`` describe, reopened whenever it is lost (module docstring).

    The first open is :func:`open_bus`'s and fails as it does (a node started with no bus says so); later
    losses are survived. ``opener``: how the inner bus is opened (default :func:`open_bus`)."""

    def __init__(
        self,
        settings: TransportSettings,
        *,
        on_change: OnChange | None = None,
        opener: Callable[[TransportSettings], can.BusABC] = open_bus,
    ) -> None:
        self.settings = settings
        self.on_change = on_change
        self.stats = OutageStats()
        self._open = opener
        self._lock = threading.Lock()
        self._closed = threading.Event()
        self._inner: can.BusABC | None = opener(settings)
        self._down_at = 0.0
        self._backoff_s = BACKOFF_FIRST_S
        self._next_try = 0.0
        self._next_health = time.monotonic() + HEALTH_EVERY_S
        super().__init__(channel=settings.channel)
        self.channel_info = f"{settings.describe()} (reconnecting)"

    @property
    def is_up(self) -> bool:
        return self._inner is not None

    # ------------------------------------------------------------------ python-can
    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        inner = self._inner
        if inner is None:
            self._wait_and_reopen(1.0 if timeout is None else timeout)
            return None, True
        try:
            msg = inner.recv(timeout)
        except (can.CanError, OSError, ValueError) as exc:
            self._went_down(inner, f"receive failed: {_first_line(exc)}")
            return None, True
        if msg is not None and msg.is_error_frame and msg.arbitration_id & CAN_ERR_BUSOFF:
            self._went_down(inner, "bus-off (error frame)")
            return None, True
        now = time.monotonic()
        if msg is None or now >= self._next_health:
            self._next_health = now + HEALTH_EVERY_S
            reason = self._health(inner)
            if reason:
                self._went_down(inner, reason)
        return msg, True

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        """Send on the live bus; while the bus is down the frame is dropped (counted). A send error that
        comes with a lost link starts an outage; any other (e.g. a full transmit queue) is raised."""
        inner = self._inner
        if inner is None:
            self.stats.frames_dropped += 1
            return
        try:
            inner.send(msg, timeout)
        except (can.CanError, OSError) as exc:
            reason = self._health(inner, sent_failed=True)
            if reason is None:
                raise
            self.stats.frames_dropped += 1
            self._went_down(inner, f"send failed: {_first_line(exc)} ({reason})")

    def shutdown(self) -> None:
        self._closed.set()
        with self._lock:
            inner, self._inner = self._inner, None
        if inner is not None:
            inner.shutdown()
        super().shutdown()

    # ------------------------------------------------------------------ outage
    def _health(self, inner: can.BusABC, *, sent_failed: bool = False) -> str | None:
        if self.settings.interface == "socketcand":
            if sent_failed or _server_closed(inner):
                return "socketcand server closed the connection"
            return None
        if self.settings.interface == "socketcan":
            return link_down_reason(self.settings)
        return None

    def _went_down(self, inner: can.BusABC, reason: str) -> None:
        with self._lock:
            if self._inner is not inner or self._closed.is_set():
                return  # another thread saw it first, or we are closing
            self._inner = None
            self._down_at = time.monotonic()
            self._backoff_s = BACKOFF_FIRST_S
            self._next_try = self._down_at + self._backoff_s
            self.stats.outages += 1
            self.stats.last_reason = reason
        log.warning("bus %s lost: %s; retrying", self.settings.describe(), reason)
        try:
            inner.shutdown()
        except Exception as exc:  # the transport is gone already
            log.debug("shutdown of the lost bus: %s", exc)
        self._notify(False, reason)

    def _wait_and_reopen(self, timeout: float) -> None:
        wait = self._next_try - time.monotonic()
        if wait > timeout:
            self._closed.wait(timeout)
            return
        if wait > 0 and self._closed.wait(wait):
            return
        self.stats.attempts += 1
        reason = link_down_reason(self.settings)
        inner = None
        if reason is None:
            try:
                inner = self._open(self.settings)
            except (can.CanError, OSError, ValueError) as exc:
                reason = f"reopen failed: {_first_line(exc)}"
        if inner is None:
            self._backoff_s = min(2 * self._backoff_s, BACKOFF_MAX_S)
            self._next_try = time.monotonic() + self._backoff_s
            log.debug("bus %s still down: %s", self.settings.describe(), reason)
            return
        with self._lock:
            if self._closed.is_set():
                inner.shutdown()
                return
            self._inner = inner
            down_s = time.monotonic() - self._down_at
            self.stats.down_s += down_s
            self.stats.reopens += 1
            self._next_health = time.monotonic() + HEALTH_EVERY_S
        log.warning(
            "bus %s back after %.2f s (%d frames dropped so far)",
            self.settings.describe(),
            down_s,
            self.stats.frames_dropped,
        )
        self._notify(True, f"back after {down_s:.2f} s")

    def _notify(self, up: bool, reason: str) -> None:
        if self.on_change is None:
            return
        try:
            self.on_change(up, reason)
        except Exception:  # never into the notifier thread or a sender
            log.exception("bus change handler failed")
