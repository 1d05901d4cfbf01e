"""Shared plumbing of the operator commands: the bus options, network settings, opening the bus, and
the one-line failure of a command. Talking to a node (its name, EDS, SDO by name, heartbeats, values)
is :mod:`telethermo.remote`.

Every command takes the same bus options (:func:`add_bus_options`): ``--network FILE`` (default
bus_config/network.toml), ``--bus`` (``socketcan:vcan0``, ``virtual:NAME``,
``socketcand://127.0.0.1:29536/telethermo``) or ``-i/-c/-b``; the bus is resolved in python-can's order by
:func:`telethermo.transport.resolve.resolve_bus`. User errors raise
:class:`telethermo.remote.errors.UserError` (exit 2); runtime failures (a node that does not answer, an
SDO abort) raise :class:`telethermo.remote.errors.Failure`, turned into one line on stderr and exit 1 by
:func:`failures`.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import logging
import os
import sys
from typing import Callable, Iterator

import can
import canopen

from telethermo.device.netconfig import NetworkConfig, NetworkConfigError, load_network
from telethermo.cli.main import EXIT_FAIL
from telethermo.remote.errors import Failure, UserError
from telethermo.transport.bus import TransportError, TransportSettings, open_bus
from telethermo.transport.busargs import add_bus_arguments
from telethermo.transport.published import state_file
from telethermo.transport.resolve import ResolvedBus, resolve_bus


def failures(run: Callable[[argparse.Namespace], int]) -> Callable[[argparse.Namespace], int]:
    """Decorate a command's ``run``: :class:`Failure` -> one line on stderr and exit 1."""

    @functools.wraps(run)
    def wrapper(args: argparse.Namespace) -> int:
        try:
            return run(args)
        except Failure as exc:
            print(f"telethermo {args.command}: {exc}", file=sys.stderr)
            return EXIT_FAIL
        except BrokenPipeError:  # the reader went away (| head): not an error of ours
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            return 0

    return wrapper


# --- options ------------------------------------------------------------------------------------
def add_bus_options(p: argparse.ArgumentParser) -> None:
    g = add_bus_arguments(p)
    g.add_argument("--network", metavar="FILE", help="network settings (default: bus_config/network.toml)")
    g.add_argument(
        "--timeout", type=float, default=1.0, metavar="S", help="SDO response timeout, s (default 1.0)"
    )


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
        return resolve_bus(
            net,
            bus=getattr(args, "bus", None),
            interface=getattr(args, "interface", None),
            channel=getattr(args, "channel", None),
            bitrate=getattr(args, "bitrate", None),
        )
    except TransportError as exc:
        raise UserError(str(exc)) from None


def transport(args: argparse.Namespace, net: NetworkConfig) -> TransportSettings:
    return resolved_bus(args, net).settings


def open_can(args: argparse.Namespace, net: NetworkConfig) -> tuple[can.BusABC, TransportSettings]:
    """Open the bus; Failure (exit 1) if it cannot be reached."""
    rb = resolved_bus(args, net)
    ts = rb.settings
    if ts.interface == "virtual" and rb.source == str(net.path):
        print(
            f"telethermo {getattr(args, 'command', '')}: note: {ts.describe()} (from {net.path}) "
            "is a bus inside this process only, and no hub or session is running "
            f"(none in {state_file()}); give the bus with "
            "--bus or -i/-c, CAN_INTERFACE/CAN_CHANNEL or ~/.canrc, or start telethermo-hub",
            file=sys.stderr,
        )
    # python-can's socketcand client logs every TCP read that splits a frame; not news to an operator
    logging.getLogger("can.interfaces.socketcand").setLevel(logging.ERROR)
    try:
        return open_bus(ts), ts
    except TransportError as exc:
        raise UserError(str(exc)) from None
    except (can.CanError, OSError, ValueError, ImportError) as exc:
        raise Failure(f"cannot open bus {ts.describe()} (from {rb.source}): {exc}") from None
    except Exception as exc:  # an interface whose driver library is missing fails in its own ways
        raise Failure(
            f"cannot open bus {ts.describe()} (from {rb.source}): {type(exc).__name__}: {exc}; "
            f"is the {ts.interface} driver library installed?"
        ) from None


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
