"""The bus factory: a python-can bus chosen by configuration, never hard-coded (DESIGN.md §5).

Supported by name (any other python-can interface works through ``options``):

- ``socketcan``: a Linux SocketCAN interface (``vcan0``, ``can0``); the bitrate of a real ``can0``
  is set by ``ip link``, not here.
- ``virtual``: python-can's in-process bus (threads of one process only).
- ``socketcand``: python-can's socketcand client (``tcp_tune=True``) against a socketcand server,
  e.g. our loopback hub (``telethermo-hub``) for two processes on a kernel without CAN.

A transport is written either as a table (the ``[bus]`` table of the network settings file; ``host`` and
``port`` may also sit at its top level)::

    [bus]
    interface = "socketcand"
    channel = "vcan0"
    [bus.options]
    host = "127.0.0.1"
    port = 29536

or as one string (command-line override ``--bus``)::

    socketcan:vcan0    virtual:tt    socketcand://127.0.0.1:29536/vcan0    pcan:PCAN_USBBUS1
"""

from __future__ import annotations

import logging
import errno
import os
from dataclasses import dataclass, field, replace
from typing import Any, Mapping

import can

#: Bitrate of the telethermo network, bit/s (DESIGN.md §4); used for bus-load figures too.
DEFAULT_BITRATE = 1_000_000

_KNOWN_KEYS = {"interface", "channel", "host", "port", "bitrate", "options"}


class TransportError(ValueError):
    """A transport description that cannot be used; the message names the source and the field."""


@dataclass(frozen=True)
class TransportSettings:
    """Which python-can bus to open.

    Attributes:
        interface: python-can interface name ("socketcan", "virtual", "socketcand", "pcan", ...).
        channel: the interface's channel ("vcan0", "can0", a virtual bus name, ...).
        bitrate: nominal bitrate, bit/s (passed to interfaces that take one).
        host: socketcand server address (socketcand only).
        port: socketcand server TCP port (socketcand only).
        options: further keyword arguments for ``can.Bus`` (interface specific).
    """

    interface: str
    channel: str
    bitrate: int = DEFAULT_BITRATE
    host: str | None = None
    port: int | None = None
    options: Mapping[str, Any] = field(default_factory=dict)

    def describe(self) -> str:
        """The one-string form (see module docstring)."""
        if self.interface == "socketcand":
            return f"socketcand://{self.host}:{self.port}/{self.channel}"
        return f"{self.interface}:{self.channel}"

    def with_overrides(self, **changes: Any) -> "TransportSettings":
        return replace(self, **changes)


def _fail(source: str, fieldname: str, problem: str) -> TransportError:
    return TransportError(f"{source}: bus.{fieldname}: {problem}")


def check_interface(name: Any, source: str = "transport") -> str:
    """``name`` if python-can knows the interface (its own or a plugin's); TransportError otherwise."""
    if not isinstance(name, str) or not name:
        raise _fail(source, "interface", f"expected a python-can interface name, got {name!r}")
    if name not in can.VALID_INTERFACES:
        raise _fail(
            source,
            "interface",
            f"unknown python-can interface {name!r}; expected one of "
            f"{', '.join(sorted(can.VALID_INTERFACES))}",
        )
    return name


def validate(settings: TransportSettings, source: str = "transport") -> TransportSettings:
    """Check ``settings``; raise :class:`TransportError` naming ``source`` and the field."""
    check_interface(settings.interface, source)
    if not isinstance(settings.channel, str) or not settings.channel:
        raise _fail(source, "channel", f"expected a channel name such as 'vcan0', got {settings.channel!r}")
    if (
        not isinstance(settings.bitrate, int)
        or isinstance(settings.bitrate, bool)
        or not (10_000 <= settings.bitrate <= 8_000_000)
    ):
        raise _fail(source, "bitrate", f"expected an integer 10000..8000000 bit/s, got {settings.bitrate!r}")
    if settings.interface == "socketcand":
        if not isinstance(settings.host, str) or not settings.host:
            raise _fail(source, "host", "socketcand needs the server address, e.g. '127.0.0.1'")
        if (
            not isinstance(settings.port, int)
            or isinstance(settings.port, bool)
            or not (1 <= settings.port <= 65535)
        ):
            raise _fail(
                source, "port", f"socketcand needs the server TCP port 1..65535, got {settings.port!r}"
            )
    if not isinstance(settings.options, Mapping):
        raise _fail(source, "options", "expected a table of extra can.Bus arguments")
    return settings


def settings_from_mapping(table: Mapping[str, Any], source: str = "transport") -> TransportSettings:
    """Build settings from a ``[bus]`` table (e.g. of bus_config/network.toml)."""
    if not isinstance(table, Mapping):
        raise TransportError(f"{source}: bus: expected a table, got {type(table).__name__}")
    unknown = set(table) - _KNOWN_KEYS
    if unknown:
        raise _fail(source, sorted(unknown)[0], f"unknown field; expected one of {sorted(_KNOWN_KEYS)}")
    for key in ("interface", "channel"):
        if key not in table:
            raise _fail(source, key, "missing")
    options = table.get("options", {})
    if not isinstance(options, Mapping):
        raise _fail(source, "options", "expected a table of extra can.Bus arguments")
    options = dict(options)
    # socketcand's server address may sit at the top level or among the can.Bus options
    host = table.get("host", options.pop("host", None))
    port = table.get("port", options.pop("port", None))
    settings = TransportSettings(
        interface=table["interface"],
        channel=table["channel"],
        bitrate=table.get("bitrate", DEFAULT_BITRATE),
        host=host,
        port=port,
        options=options,
    )
    return validate(settings, source)


def parse_bus_string(
    text: str, *, bitrate: int = DEFAULT_BITRATE, source: str = "--bus"
) -> TransportSettings:
    """Parse ``INTERFACE:CHANNEL`` or ``socketcand://HOST:PORT/CHANNEL`` (see module docstring)."""
    text = text.strip()
    if text.startswith("socketcand://"):
        rest = text[len("socketcand://") :]
        hostport, sep, channel = rest.partition("/")
        host, colon, port_text = hostport.rpartition(":")
        if not sep or not colon or not channel:
            raise TransportError(f"{source}: {text!r}: expected socketcand://HOST:PORT/CHANNEL")
        host = host.strip("[]")
        try:
            port = int(port_text)
        except ValueError:
            raise TransportError(f"{source}: {text!r}: port {port_text!r} is not an integer") from None
        return validate(
            TransportSettings("socketcand", channel, bitrate, host=host, port=port), f"{source} {text!r}"
        )
    interface, colon, channel = text.partition(":")
    if not colon or not interface or not channel:
        raise TransportError(
            f"{source}: {text!r}: expected INTERFACE:CHANNEL (e.g. socketcan:vcan0) "
            "or socketcand://HOST:PORT/CHANNEL"
        )
    return validate(TransportSettings(interface, channel, bitrate), f"{source} {text!r}")


def open_bus(settings: TransportSettings) -> can.BusABC:
    """Open the python-can bus ``settings`` describe. The caller shuts it down."""
    validate(settings)
    kwargs: dict[str, Any] = dict(settings.options)
    if settings.interface == "socketcan":
        try:
            bus = can.Bus(interface="socketcan", channel=settings.channel, **kwargs)
        except OSError as exc:
            raise OSError(exc.errno, socketcan_hint(exc, settings.channel)) from None
        enlarge_receive_buffer(bus)
        return bus
    if settings.interface == "virtual":
        kwargs.setdefault("receive_own_messages", False)
        return can.Bus(interface="virtual", channel=settings.channel, **kwargs)
    if settings.interface == "socketcand":
        kwargs.setdefault("tcp_tune", os.name != "nt")
        return can.Bus(
            interface="socketcand", channel=settings.channel, host=settings.host, port=settings.port, **kwargs
        )
    return can.Bus(interface=settings.interface, channel=settings.channel, bitrate=settings.bitrate, **kwargs)


def socketcan_hint(exc: OSError, channel: str) -> str:
    """What a SocketCAN open error means for an operator (the kernel's errno alone says little)."""
    if exc.errno == errno.EAFNOSUPPORT:
        return (
            "this kernel has no SocketCAN (address family AF_CAN not supported): use a Linux kernel with CAN "
            "support (modprobe can vcan) or another interface (-i, e.g. socketcand or virtual)"
        )
    if exc.errno in (errno.ENODEV, errno.ENXIO):
        return f"no CAN interface {channel!r} on this machine (ip -details link show type can, or type vcan)"
    if exc.errno == errno.ENETDOWN:
        return f"CAN interface {channel!r} is down (ip link set {channel} up)"
    return exc.strerror or str(exc)


#: SocketCAN receive buffer asked for, bytes (the kernel default, ~208 kB, holds only ~250 frames)
RCVBUF_BYTES = 8 * 1024 * 1024


def enlarge_receive_buffer(bus: can.BusABC, size: int = RCVBUF_BYTES) -> int:
    """Give a SocketCAN bus a bigger socket receive buffer; returns the size in force, bytes
    (0: not a socket).

    Each CAN frame costs the socket buffer a whole kernel buffer (~800 bytes), so the default holds ~250
    frames: a reader that is not scheduled for a few milliseconds while a lockstep session or a 1 kHz
    SYNC runs overflows it, and the kernel drops frames (measured: a CLI inside the vcan VM lost 1 % of an
    identification stream and then an SDO response). SO_RCVBUFFORCE (root or CAP_NET_ADMIN) may exceed
    net.core.rmem_max; SO_RCVBUF is capped by it. candump's ``-r`` does the same.
    """
    import socket

    sock = getattr(bus, "socket", None)
    if sock is None:
        return 0
    for opt in (getattr(socket, "SO_RCVBUFFORCE", 33), socket.SO_RCVBUF):
        try:
            sock.setsockopt(socket.SOL_SOCKET, opt, size)
            break
        except OSError:
            continue
    try:
        return int(sock.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF))
    except OSError:
        return 0


class FrameLog(can.Listener):
    """Every data frame a bus receives, in order, as ``(timestamp s, COB-ID, data)``: a bus analyser for tests
    and benchmarks (a client no node knows about). Frames are collected by python-can's own
    :class:`can.Notifier` thread. ``bus``: a transport string (``socketcand://127.0.0.1:PORT/telethermo``,
    ``socketcan:vcan0``, ...). Call :meth:`close` when done."""

    def __init__(self, bus: str) -> None:
        import threading

        logging.getLogger("can.interfaces.socketcand").setLevel(logging.ERROR)  # split TCP reads are not news
        self.bus = open_bus(parse_bus_string(bus))
        self._frames: list[tuple[float, int, bytes]] = []
        self._lock = threading.Lock()
        self._notifier = can.Notifier(self.bus, [self], timeout=0.05)

    def on_message_received(self, msg: can.Message) -> None:
        if not msg.is_error_frame:
            with self._lock:
                self._frames.append((msg.timestamp, msg.arbitration_id, bytes(msg.data)))

    def snapshot(self) -> list[tuple[float, int, bytes]]:
        """The frames so far (a copy)."""
        with self._lock:
            return list(self._frames)

    def __len__(self) -> int:
        return len(self._frames)

    def close(self) -> None:
        self._notifier.stop()
        self.bus.shutdown()


def frame_bits(dlc: int, *, extended: bool = False) -> int:
    """Bits a classic CAN data frame of ``dlc`` bytes occupies on the wire, worst-case stuffing.

    11-bit ID: 47 + 8·dlc bits before stuffing (SOF..EOF and 3 bits interframe space), of which
    34 + 8·dlc are subject to stuffing (one stuff bit per 4 at worst). 29-bit ID: 67 + 8·dlc, 54 + 8·dlc.
    """
    if not 0 <= dlc <= 8:
        raise ValueError(f"dlc {dlc}: expected 0..8")
    fixed, stuffable = (67, 54) if extended else (47, 34)
    return fixed + 8 * dlc + (stuffable + 8 * dlc - 1) // 4


def bus_load(frames_per_s: Mapping[int, float], bitrate: int = DEFAULT_BITRATE) -> float:
    """Fraction of the bus time used by classic 11-bit frames: ``{dlc: frames/s}`` at ``bitrate`` bit/s."""
    return sum(rate * frame_bits(dlc) for dlc, rate in frames_per_s.items()) / bitrate
