"""Shared plumbing of the operator commands: network settings, opening the bus, naming nodes,
EDS look-ups, SDO access with clear errors.

Every command takes the same bus options (:func:`add_bus_options`): ``--network FILE`` (default
bus_config/network.toml), ``--bus`` (``socketcan:vcan0``, ``virtual:NAME``,
``socketcand://127.0.0.1:29536/telethermo``) or ``-i/-c/-b``; the bus is resolved in python-can's order by
:func:`telethermo.transport.resolve.resolve_bus`. User errors raise
:class:`telethermo.cli.main.UserError` (exit 2); runtime failures (a node that does not answer, an
SDO abort) raise :class:`Failure`, turned into one line on stderr and exit 1 by :func:`failures`.
"""
from __future__ import annotations

import argparse
import contextlib
import functools
import logging
import math
import struct
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterator

import can
import canopen
from canopen.sdo.exceptions import SdoAbortedError, SdoCommunicationError

from telethermo.canopen_dev.cia301 import sdo_abort_text
from telethermo.canopen_dev.eds_info import EdsError, EdsInfo, VarInfo
from telethermo.canopen_dev.netconfig import NetworkConfig, NetworkConfigError, load_network
from telethermo.cli.main import EXIT_FAIL, UserError
from telethermo.transport.bus import TransportError, TransportSettings, open_bus
from telethermo.transport.busargs import add_bus_arguments
from telethermo.transport.resolve import ResolvedBus, resolve_bus


class Failure(Exception):
    """A runtime failure (node silent, SDO refused): one line on stderr, exit 1."""


class Refused(Failure):
    """A node refused an SDO write: ``code`` is its abort code."""

    def __init__(self, message: str, code: int) -> None:
        super().__init__(message)
        self.code = code


def failures(run: Callable[[argparse.Namespace], int]) -> Callable[[argparse.Namespace], int]:
    """Decorate a command's ``run``: :class:`Failure` -> one line on stderr and exit 1."""

    @functools.wraps(run)
    def wrapper(args: argparse.Namespace) -> int:
        try:
            return run(args)
        except Failure as exc:
            print(f"telethermo {args.command}: {exc}", file=sys.stderr)
            return EXIT_FAIL
        except BrokenPipeError:   # the reader went away (| head): not an error of ours
            import os
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            return 0

    return wrapper


# --- options ------------------------------------------------------------------------------------
def add_bus_options(p: argparse.ArgumentParser) -> None:
    g = add_bus_arguments(p)
    g.add_argument("--network", metavar="FILE", help="network settings (default: bus_config/network.toml)")
    g.add_argument("--timeout", type=float, default=1.0, metavar="S",
                   help="SDO response timeout, s (default 1.0)")


def network(args: argparse.Namespace) -> NetworkConfig:
    try:
        return load_network(getattr(args, "network", None))
    except NetworkConfigError as exc:
        raise UserError(str(exc)) from None
    except OSError as exc:
        raise UserError(f"{args.network}: cannot read network settings ({exc.strerror or exc})") from None


def resolved_bus(args: argparse.Namespace, net: NetworkConfig) -> ResolvedBus:
    """The bus of this command and where the setting came from (:func:`resolve_bus`)."""
    try:
        return resolve_bus(net, bus=getattr(args, "bus", None), interface=getattr(args, "interface", None),
                           channel=getattr(args, "channel", None), bitrate=getattr(args, "bitrate", None))
    except TransportError as exc:
        raise UserError(str(exc)) from None


def transport(args: argparse.Namespace, net: NetworkConfig) -> TransportSettings:
    return resolved_bus(args, net).settings


def open_can(args: argparse.Namespace, net: NetworkConfig) -> tuple[can.BusABC, TransportSettings]:
    """Open the bus; Failure (exit 1) if it cannot be reached."""
    rb = resolved_bus(args, net)
    ts = rb.settings
    if ts.interface == "virtual" and rb.source == str(net.path):
        from telethermo.transport.published import state_file
        print(f"telethermo {getattr(args, 'command', '')}: note: {ts.describe()} (from {net.path}) is a bus inside "
              f"this process only, and no hub or session is running (none in {state_file()}); give the bus with "
              "--bus or -i/-c, CAN_INTERFACE/CAN_CHANNEL or ~/.canrc, or start telethermo-hub", file=sys.stderr)
    # python-can's socketcand client logs every TCP read that splits a frame; not news to an operator
    logging.getLogger("can.interfaces.socketcand").setLevel(logging.ERROR)
    try:
        return open_bus(ts), ts
    except TransportError as exc:
        raise UserError(str(exc)) from None
    except (can.CanError, OSError, ValueError, ImportError) as exc:
        raise Failure(f"cannot open bus {ts.describe()} (from {rb.source}): {exc}") from None
    except Exception as exc:   # an interface whose driver library is missing fails in its own ways
        raise Failure(f"cannot open bus {ts.describe()} (from {rb.source}): {type(exc).__name__}: {exc}; "
                      f"is the {ts.interface} driver library installed?") from None


@contextlib.contextmanager
def canopen_network(args: argparse.Namespace, net: NetworkConfig) -> Iterator[canopen.Network]:
    """A canopen Network on the configured bus, disconnected on exit."""
    bus, _ = open_can(args, net)
    # the commands report SDO failures themselves, in one line; canopen would log them again
    logging.getLogger("canopen.sdo.client").setLevel(logging.CRITICAL)
    nw = canopen.Network(bus)
    nw.notifier = can.Notifier(bus, nw.listeners, 0.1)
    try:
        yield nw
    finally:
        try:
            nw.disconnect()
        except Exception:  # a broken connection must not hide the command's own result
            pass


# --- nodes and dictionaries -----------------------------------------------------------------------
@dataclass(frozen=True)
class Target:
    """A node as the operator names it (``eds`` None: a node-ID outside the network file, e.g. for ``sdo``)."""

    role: str
    node_id: int
    eds: Path | None


def node_targets(net: NetworkConfig) -> list[Target]:
    return sorted((Target(role, n.node_id, Path(n.eds)) for role, n in net.nodes.items()), key=lambda t: t.node_id)


def resolve_node(net: NetworkConfig, text: str) -> Target:
    """``master`` / ``slave`` / a node-ID -> Target; UserError listing the known nodes otherwise."""
    known = node_targets(net)
    for t in known:
        if text.lower() == t.role or text == str(t.node_id) or (text.lower().startswith("0x") and
                                                                 _int(text) == t.node_id):
            return t
    names = ", ".join(f"{t.role} ({t.node_id})" for t in known)
    raise UserError(f"unknown node {text!r}; expected one of {names} (from {net.path})")


def _int(text: str) -> int | None:
    try:
        return int(text, 0)
    except ValueError:
        return None


@functools.lru_cache(maxsize=16)
def _parsed_eds(path: str, mtime_ns: int) -> EdsInfo:
    return EdsInfo(path)


def eds_info(target: Target) -> EdsInfo:
    """The node's EDS, parsed once per file version (a parse takes ~20 ms; a command may look up hundreds
    of names, e.g. identify's SDO set-up and model load)."""
    try:
        try:
            mtime = Path(target.eds).stat().st_mtime_ns
        except OSError:
            return EdsInfo(target.eds)   # names the file and what is wrong with it
        return _parsed_eds(str(target.eds), mtime)
    except EdsError as exc:
        raise UserError(str(exc)) from None


def lookup(target: Target, name: str) -> VarInfo:
    """A variable of the node's EDS by name or number; UserError with suggestions if unknown."""
    try:
        return eds_info(target).get(name)
    except KeyError as exc:
        raise UserError(exc.args[0]) from None


# --- SDO ------------------------------------------------------------------------------------------
def abort_text(code: int) -> str:
    return f"SDO abort 0x{code:08X}: {sdo_abort_text(code)}"


def remote(nw: canopen.Network, target: Target, timeout_s: float = 1.0) -> canopen.RemoteNode:
    """An SDO client of ``target``. Its object dictionary stays empty: the commands address objects by
    index and subindex from :func:`eds_info` (parsed once), so canopen need not parse the EDS again."""
    node = canopen.RemoteNode(target.node_id, canopen.ObjectDictionary())
    node.sdo.RESPONSE_TIMEOUT = timeout_s
    node.sdo.MAX_RETRIES = 1   # canopen counts attempts: 1 = no retry (0 would retry forever)
    nw.add_node(node)
    return node


def _struct(info: VarInfo) -> struct.Struct | None:
    return {0x0001: struct.Struct("<?"), 0x0002: struct.Struct("<b"), 0x0003: struct.Struct("<h"),
            0x0004: struct.Struct("<i"), 0x0005: struct.Struct("<B"), 0x0006: struct.Struct("<H"),
            0x0007: struct.Struct("<I"), 0x0008: struct.Struct("<f"), 0x0011: struct.Struct("<d"),
            0x0015: struct.Struct("<q"), 0x001B: struct.Struct("<Q")}.get(info.data_type)


def decode(info: VarInfo, data: bytes) -> Any:
    st = _struct(info)
    if st is not None:
        if len(data) < st.size:
            raise Failure(f"0x{info.index:04X}:{info.subindex:02X} {info.key}: {len(data)} bytes, "
                          f"expected {st.size} for {info.type_name}")
        return st.unpack_from(data)[0]
    if info.data_type == 0x0009:
        return data.decode("ascii", "replace").rstrip("\x00")
    return data.hex()


def parse_value(info: VarInfo, text: str) -> float | int | bool:
    """Parse an operator's value for ``info``'s type; UserError naming the parameter otherwise."""
    t = text.strip()
    try:
        if info.data_type in (0x0008, 0x0011):
            v: Any = float(t)
        elif info.data_type == 0x0001:
            low = t.lower()
            if low in ("1", "true", "on", "yes"):
                return True
            if low in ("0", "false", "off", "no"):
                return False
            raise ValueError
        elif _struct(info) is not None:
            v = int(t, 0)
        else:
            raise UserError(f"{info.key}: setting a {info.type_name} is not supported here")
    except ValueError:
        raise UserError(f"{info.key}: expected a {info.type_name} value, got {text!r}") from None
    if isinstance(v, float) and not math.isfinite(v) and not math.isnan(v):
        raise UserError(f"{info.key}: expected a finite number, got {text!r}")
    return v


def check_range(info: VarInfo, value: float | int | bool) -> None:
    """Refuse locally what the node would refuse: out of the EDS range, or out of the type's range."""
    if isinstance(value, bool):
        return
    if isinstance(value, float) and math.isnan(value):
        raise UserError(f"{info.key}: NaN is not a value; allowed range {info.range_text() or 'any number'}")
    if info.low is not None and value < info.low or info.high is not None and value > info.high:
        raise UserError(f"{info.key} = {value:g} is out of range {info.range_text()}; not sent")
    st = _struct(info)
    if st is not None and isinstance(value, int):
        try:
            st.pack(value)
        except struct.error:
            raise UserError(f"{info.key} = {value} does not fit a {info.type_name}; not sent") from None


def sdo_read(node: canopen.RemoteNode, target: Target, info: VarInfo) -> Any:
    """Read one variable by SDO; Failure with the abort text or 'did not answer'."""
    try:
        data = node.sdo.upload(info.index, info.subindex)
    except SdoAbortedError as exc:
        raise Failure(f"{target.role} (node {target.node_id}) refused to read {info.key}: "
                      f"{abort_text(exc.code)}") from None
    except SdoCommunicationError as exc:
        raise Failure(f"{target.role} (node {target.node_id}) did not answer reading {info.key} ({exc})") from None
    return decode(info, data)


def sdo_write(node: canopen.RemoteNode, target: Target, info: VarInfo, value: Any) -> None:
    """Write one variable by SDO (expedited); Failure with the abort code and its meaning."""
    st = _struct(info)
    if st is None:
        raise UserError(f"{info.key}: writing a {info.type_name} is not supported")
    try:
        node.sdo.download(info.index, info.subindex, st.pack(value))
    except SdoAbortedError as exc:
        raise Refused(f"{target.role} (node {target.node_id}) refused {info.key} = {value}: "
                      f"{abort_text(exc.code)}", exc.code) from None
    except SdoCommunicationError as exc:
        raise Failure(f"{target.role} (node {target.node_id}) did not answer writing {info.key} ({exc})") from None


def fmt(value: Any, info: VarInfo) -> str:
    """A value with its unit, floats to 4 decimals (REAL32 carries ~7 digits)."""
    if isinstance(value, float):
        txt = f"{value:.4f}".rstrip("0").rstrip(".") if math.isfinite(value) else str(value)
        if txt in ("-0", ""):
            txt = "0"
    else:
        txt = str(value)
    return f"{txt} {info.unit}".rstrip()


# --- heartbeats -------------------------------------------------------------------------------------
class HeartbeatWatch(can.Listener):
    """Every heartbeat / boot-up on the bus: node-ID -> (last state byte, time, count, boot-ups)."""

    def __init__(self) -> None:
        import threading
        self.cond = threading.Condition()
        self.last: dict[int, tuple[int, float]] = {}
        self.boot_ups: dict[int, int] = {}
        self.count: dict[int, int] = {}

    def on_message_received(self, msg: can.Message) -> None:
        cob = msg.arbitration_id
        if msg.is_extended_id or msg.is_remote_frame or not 0x701 <= cob <= 0x77F or len(msg.data) != 1:
            return
        n = cob - 0x700
        with self.cond:
            self.last[n] = (msg.data[0] & 0x7F, msg.timestamp)
            self.count[n] = self.count.get(n, 0) + 1
            if msg.data[0] == 0:
                self.boot_ups[n] = self.boot_ups.get(n, 0) + 1
            self.cond.notify_all()

    def wait_for(self, pred: Callable[[], bool], timeout_s: float) -> bool:
        with self.cond:
            return self.cond.wait_for(pred, timeout_s)

    def state_name(self, node_id: int) -> str:
        from telethermo.monitor.cia301 import NMT_UNKNOWN, nmt_state_name
        with self.cond:
            s = self.last.get(node_id)
        return nmt_state_name(s[0]) if s else NMT_UNKNOWN


def watch_heartbeats(nw: canopen.Network) -> HeartbeatWatch:
    w = HeartbeatWatch()
    nw.notifier.add_listener(w)
    return w


def heartbeat_wait_s(net: NetworkConfig) -> float:
    """How long to listen to be sure to hear every live node's heartbeat once, s."""
    return max(0.05, 2.5 * net.heartbeat.producer_ms / 1000.0)
