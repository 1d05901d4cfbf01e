"""A loopback-only CAN hub speaking the socketcand protocol (raw mode), for two processes on a
machine whose kernel has no CAN (DESIGN.md §5).

Clients are python-can's own ``socketcand`` interface::

    can.Bus(interface="socketcand", host="127.0.0.1", port=PORT, channel="vcan0", tcp_tune=True)

Protocol: :mod:`telethermo.transport.socketcand` (the subset python-can's client uses).

Bus semantics: each channel name is one bus; a frame sent by one client goes to every OTHER client
in raw mode on the same channel (no echo, as on a CAN bus), in the order the hub received them,
without loss (a client that cannot keep up is buffered, and disconnected only past
``max_backlog_bytes``, like a node going bus-off). Malformed commands are counted and ignored.

A client that just entered raw mode gets the frames of its first ``join_grace_s`` held back and
then delivered in order: python-can's client reads the ``< ok >`` of ``< rawmode >`` with one
``recv`` and fails if a frame arrives glued to it.

The hub binds 127.0.0.1 (or ::1) only, and stops by itself when its parent process ends
(``parent_pid``) or after ``idle_timeout_s`` without any client.
"""

from __future__ import annotations

import argparse
import ipaddress
import logging
import os
import selectors
import socket
import sys
import threading
import signal
import time
from collections import deque
from dataclasses import dataclass, field

from telethermo.atomic import write_text_atomic
from telethermo.transport.procwatch import process_alive
from telethermo.transport.published import publish, unpublish
from telethermo.transport.socketcand import format_frame, parse_send

log = logging.getLogger(__name__)

LOOPBACK_HOSTS = ("127.0.0.1", "::1", "localhost")
_MAX_COMMAND_CHARS = 256  # the longest legal command ("< send 1FFFFFFF 8 ff ... >") is ~50 chars


@dataclass(frozen=True)
class HubConfig:
    """Settings of a :class:`Hub`.

    Attributes:
        host: address to bind; loopback only (127.0.0.1, ::1 or localhost).
        port: TCP port; 0 = let the kernel choose (read :attr:`Hub.port` after :meth:`Hub.start`).
        idle_timeout_s: stop after this many seconds with no client connected, s (0 = never).
        parent_pid: stop when this process no longer exists (None = do not watch).
        parent_is_own: ``parent_pid`` is the hub's own parent (the default of ``telethermo-hub``): then a
            re-parenting (to init or a subreaper) also says it ended, as does a parent that ended before the
            hub looked (the hub then finds init for its parent). A process named by ``--parent-pid`` is
            watched by its PID alone: the hub may be started with ``nohup``/``setsid`` beside it.
        join_grace_s: hold back frames for a client that just entered raw mode this long, s.
        max_backlog_bytes: a client whose unsent backlog exceeds this is disconnected, bytes.
    """

    host: str = "127.0.0.1"
    port: int = 0
    idle_timeout_s: float = 60.0
    parent_pid: int | None = None
    parent_is_own: bool = False
    join_grace_s: float = 0.2
    max_backlog_bytes: int = 16 * 1024 * 1024

    def __post_init__(self) -> None:
        if not is_loopback(self.host):
            raise ValueError(
                f"hub host {self.host!r}: expected a loopback address (127.0.0.1 or ::1); "
                "the hub never listens on a network"
            )
        if not (0 <= self.port <= 65535):
            raise ValueError(f"hub port {self.port}: expected 0..65535")
        if self.idle_timeout_s < 0 or self.join_grace_s < 0:
            raise ValueError("hub idle_timeout_s and join_grace_s must be >= 0 s")


def is_loopback(host: str) -> bool:
    """True if ``host`` names the loopback interface."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


@dataclass
class HubStats:
    """Counters of a running hub (read them from any thread; they only grow)."""

    clients_accepted: int = 0
    frames_in: int = 0
    frames_out: int = 0
    malformed: int = 0
    dropped_clients: int = 0


@dataclass
class _Client:
    sock: socket.socket
    addr: object
    inbuf: bytearray = field(default_factory=bytearray)
    outbuf: bytearray = field(default_factory=bytearray)
    channel: str | None = None
    raw: bool = False
    held: deque = field(default_factory=deque)  # frames held during the join grace period
    release_at: float = 0.0
    writing: bool = False


class Hub:
    """The socketcand-protocol hub. ``start()`` binds; ``serve_forever()`` runs until ``stop()``,
    the parent's end or the idle timeout."""

    def __init__(self, config: HubConfig | None = None) -> None:
        self.config = config or HubConfig()
        self.stats = HubStats()
        self._sel = selectors.DefaultSelector()
        self._listener: socket.socket | None = None
        self._clients: dict[int, _Client] = {}
        self._wake_r, self._wake_w = socket.socketpair()
        self._stopping = threading.Event()
        self.stop_reason = ""

    # -- lifecycle ---------------------------------------------------------------------------
    def start(self) -> int:
        """Bind and listen; return the port."""
        host = "127.0.0.1" if self.config.host == "localhost" else self.config.host
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        lst = socket.socket(family, socket.SOCK_STREAM)
        lst.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        lst.bind((host, self.config.port))
        lst.listen(16)
        lst.setblocking(False)
        self._listener = lst
        self._sel.register(lst, selectors.EVENT_READ, "listen")
        self._wake_r.setblocking(False)
        self._sel.register(self._wake_r, selectors.EVENT_READ, "wake")
        return self.port

    @property
    def port(self) -> int:
        if self._listener is None:
            raise RuntimeError("hub not started")
        return self._listener.getsockname()[1]

    @property
    def client_count(self) -> int:
        return len(self._clients)

    def stop(self, reason: str = "stopped") -> None:
        """Ask a running :meth:`serve_forever` to return (thread-safe)."""
        if not self._stopping.is_set():
            self.stop_reason = reason
            self._stopping.set()
            try:
                self._wake_w.send(b"x")
            except OSError:
                pass

    def serve_forever(self) -> str:
        """Run the hub; return why it stopped."""
        if self._listener is None:
            self.start()
        idle_since = time.monotonic()
        next_parent_check = 0.0
        try:
            while not self._stopping.is_set():
                now = time.monotonic()
                timeout = 0.5
                if any(c.held for c in self._clients.values()):
                    timeout = 0.01
                for key, events in self._sel.select(timeout):
                    tag = key.data
                    if tag == "listen":
                        self._accept()
                    elif tag == "wake":
                        try:
                            self._wake_r.recv(64)
                        except OSError:
                            pass
                    else:
                        client: _Client = tag
                        if events & selectors.EVENT_READ:
                            self._read(client)
                        if events & selectors.EVENT_WRITE and client.sock.fileno() in self._clients:
                            self._flush(client)
                now = time.monotonic()
                for client in list(self._clients.values()):
                    if client.held and now >= client.release_at:
                        while client.held:
                            client.outbuf += client.held.popleft()
                        self._flush(client)
                if self._clients:
                    idle_since = now
                elif self.config.idle_timeout_s and now - idle_since > self.config.idle_timeout_s:
                    self.stop(f"idle for {self.config.idle_timeout_s:g} s")
                if self.config.parent_pid is not None and now >= next_parent_check:
                    next_parent_check = now + 0.25
                    ppid = os.getppid()
                    reparented = self.config.parent_is_own and (ppid != self.config.parent_pid or ppid == 1)
                    if reparented or not process_alive(self.config.parent_pid):
                        self.stop(f"parent process {self.config.parent_pid} ended")
        finally:
            self._close_all()
        return self.stop_reason

    # -- I/O -----------------------------------------------------------------------------------
    def _accept(self) -> None:
        assert self._listener is not None
        try:
            sock, addr = self._listener.accept()
        except (BlockingIOError, InterruptedError):
            return
        sock.setblocking(False)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        client = _Client(sock=sock, addr=addr)
        self._clients[sock.fileno()] = client
        self._sel.register(sock, selectors.EVENT_READ, client)
        self.stats.clients_accepted += 1
        client.outbuf += b"< hi >"
        self._flush(client)
        log.info("client %s connected", addr)

    def _drop(self, client: _Client, why: str) -> None:
        fd = client.sock.fileno()
        if fd in self._clients:
            del self._clients[fd]
            try:
                self._sel.unregister(client.sock)
            except (KeyError, ValueError):
                pass
        try:
            client.sock.close()
        except OSError:
            pass
        log.info("client %s gone: %s", client.addr, why)

    def _read(self, client: _Client) -> None:
        try:
            chunk = client.sock.recv(65536)
        except (BlockingIOError, InterruptedError):
            return
        except OSError as exc:
            self._drop(client, f"receive error {exc}")
            return
        if not chunk:
            self._drop(client, "closed")
            return
        client.inbuf += chunk
        buf = client.inbuf
        pos = 0
        while True:
            start = buf.find(b"<", pos)
            if start < 0:
                if len(buf) > pos:
                    self.stats.malformed += 1  # bytes outside < >
                pos = len(buf)
                break
            if start > pos and buf[pos:start].strip():
                self.stats.malformed += 1
            end = buf.find(b">", start)
            if end < 0:
                if len(buf) - start > _MAX_COMMAND_CHARS:
                    self.stats.malformed += 1
                    pos = len(buf)
                else:
                    pos = start
                break
            self._command(client, bytes(buf[start + 1 : end]).decode("ascii", "replace").strip())
            if client.sock.fileno() not in self._clients:
                return
            pos = end + 1
        del buf[:pos]

    def _command(self, client: _Client, command: str) -> None:
        if command.startswith("send ") and client.channel is not None:
            parsed = parse_send(command)
            if parsed is None:
                self.stats.malformed += 1
                log.debug("malformed send from %s: %r", client.addr, command)
                return
            self.stats.frames_in += 1
            frame = format_frame(parsed[0], parsed[1], time.time())
            now = time.monotonic()
            for other in list(self._clients.values()):
                if other is client or not other.raw or other.channel != client.channel:
                    continue
                self.stats.frames_out += 1
                if other.held or now < other.release_at:
                    other.held.append(frame)
                else:
                    other.outbuf += frame
                    self._flush(other)
        elif command.startswith("open ") and client.channel is None:
            name = command[5:].strip()
            if not name or " " in name:
                self.stats.malformed += 1
                client.outbuf += b"< error bad channel name >"
            else:
                client.channel = name
                client.outbuf += b"< ok >"
            self._flush(client)
        elif command == "rawmode" and client.channel is not None:
            client.raw = True
            client.release_at = time.monotonic() + self.config.join_grace_s
            client.outbuf += b"< ok >"
            self._flush(client)
        elif command == "echo":
            client.outbuf += b"< echo >"
            self._flush(client)
        else:
            self.stats.malformed += 1
            log.debug("ignored command from %s: %r", client.addr, command)

    def _flush(self, client: _Client) -> None:
        if client.outbuf:
            try:
                sent = client.sock.send(client.outbuf)
                del client.outbuf[:sent]
            except (BlockingIOError, InterruptedError):
                pass
            except OSError as exc:
                self._drop(client, f"send error {exc}")
                return
        if len(client.outbuf) > self.config.max_backlog_bytes:
            self.stats.dropped_clients += 1
            self._drop(client, f"backlog over {self.config.max_backlog_bytes} bytes (client too slow)")
            return
        want_write = bool(client.outbuf)
        if want_write != client.writing:
            client.writing = want_write
            events = selectors.EVENT_READ | (selectors.EVENT_WRITE if want_write else 0)
            self._sel.modify(client.sock, events, client)

    def _close_all(self) -> None:
        for client in list(self._clients.values()):
            self._drop(client, "hub stopping")
        for sock in (self._listener, self._wake_r, self._wake_w):
            if sock is not None:
                try:
                    self._sel.unregister(sock)
                except (KeyError, ValueError):
                    pass
                sock.close()
        self._sel.close()


class HubThread:
    """A hub running in a background thread of this process (tests, benchmarks)::

    with HubThread() as hub:
        bus = can.Bus(interface="socketcand", host="127.0.0.1", port=hub.port, channel="vcan0")
    """

    def __init__(self, config: HubConfig | None = None) -> None:
        self.hub = Hub(config or HubConfig(idle_timeout_s=0))
        self._thread: threading.Thread | None = None

    @property
    def port(self) -> int:
        return self.hub.port

    def __enter__(self) -> "HubThread":
        self.hub.start()
        self._thread = threading.Thread(target=self.hub.serve_forever, name="telethermo-hub", daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.hub.stop("context exit")
        if self._thread is not None:
            self._thread.join(timeout=5)


DEFAULT_CHANNEL = "telethermo"


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="telethermo-hub",
        description="Loopback-only CAN hub speaking the socketcand protocol (python-can interface "
        "'socketcand'): every frame from one client goes to all other clients on the same "
        "channel, ordered and lossless. Prints 'telethermo-hub listening on HOST:PORT' once ready.",
    )
    parser.add_argument("--host", default="127.0.0.1", help="loopback address to bind (127.0.0.1 or ::1)")
    parser.add_argument("--port", type=int, default=0, help="TCP port (0 = any free port; default 0)")
    parser.add_argument("--port-file", help="also write the chosen port to this file (atomically)")
    parser.add_argument(
        "--idle-timeout",
        type=float,
        default=60.0,
        metavar="S",
        help="stop after S seconds with no client (0 = never; default 60)",
    )
    parser.add_argument(
        "--parent-pid",
        type=int,
        default=None,
        help="stop when this process ends, watched by its PID (so the hub may be started with nohup or "
        "setsid beside it; default: the process that started the hub, which a re-parenting also ends)",
    )
    parser.add_argument(
        "--no-parent-watch",
        action="store_true",
        help="do not stop with the parent process (a hub left running for hours: --idle-timeout 0 too)",
    )
    parser.add_argument(
        "--channel",
        default=DEFAULT_CHANNEL,
        help=f"the channel name published for clients (default {DEFAULT_CHANNEL}; the hub serves any)",
    )
    parser.add_argument(
        "--no-publish",
        action="store_true",
        help="do not publish where the hub listens (by default the commands and node programs "
        "of this user find it with no flag: telethermo.transport.published)",
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="log connections")
    return parser


def main(argv: list[str] | None = None) -> int:
    """``telethermo-hub``: run the hub until its parent ends, the idle timeout, or SIGINT/SIGTERM."""

    args = _parser().parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING, format="telethermo-hub: %(message)s"
    )
    parent = None if args.no_parent_watch else (args.parent_pid or os.getppid())
    try:
        config = HubConfig(
            host=args.host,
            port=args.port,
            idle_timeout_s=args.idle_timeout,
            parent_pid=parent,
            parent_is_own=parent is not None and not args.parent_pid,
        )
    except ValueError as exc:
        print(f"telethermo-hub: error: {exc}", file=sys.stderr)
        return 2
    hub = Hub(config)
    try:
        port = hub.start()
    except OSError as exc:
        print(f"telethermo-hub: error: cannot listen on {args.host}:{args.port}: {exc}", file=sys.stderr)
        return 1
    signal.signal(signal.SIGTERM, lambda *_: hub.stop("SIGTERM"))
    signal.signal(signal.SIGINT, lambda *_: hub.stop("SIGINT"))
    if args.port_file:
        write_text_atomic(args.port_file, f"{port}\n")
    where = f"socketcand://{'[' + args.host + ']' if ':' in args.host else args.host}:{port}/{args.channel}"
    if not args.no_publish:
        try:
            state = publish(where, "telethermo-hub")
        except OSError as exc:  # the hub works without it; the clients then need --bus
            print(f"telethermo-hub: warning: cannot publish where it listens ({exc})", file=sys.stderr)
            args.no_publish = True
    print(f"telethermo-hub listening on {args.host}:{port}", flush=True)
    if not args.no_publish:
        print(
            f"telethermo-hub: clients of this user find it with no flag ({where}, published in {state})",
            flush=True,
        )
    try:
        reason = hub.serve_forever()
    finally:
        if not args.no_publish:
            unpublish()
    s = hub.stats
    print(
        f"telethermo-hub stopped ({reason}): {s.clients_accepted} clients, {s.frames_in} frames in, "
        f"{s.frames_out} out, {s.malformed} malformed, {s.dropped_clients} dropped",
        flush=True,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
