"""The bus options of every command and node program: ``--bus`` and ``-i/-c/-b`` (python-can's names,
as ``can.logger`` and ``can.viewer`` take them). Imports nothing but argparse, so that ``--help`` stays
fast; :func:`telethermo.transport.resolve.resolve_bus` turns them into the bus."""

from __future__ import annotations

import argparse

ORDER = (
    "first wins: --bus or -i/-c/-b, then CAN_INTERFACE/CAN_CHANNEL/CAN_BITRATE, then python-can's config "
    "file (~/.canrc: [telethermo], [default]), then the network file's [bus] (its in-process virtual bus "
    "gives way to a running telethermo-hub or session)"
)


def add_bus_arguments(parser: argparse.ArgumentParser) -> argparse._ArgumentGroup:
    """Add the "bus" argument group to ``parser``; returns it (callers add their own bus options to it)."""
    g = parser.add_argument_group("bus", ORDER)
    g.add_argument(
        "--bus",
        metavar="BUS",
        help="the bus as one string: socketcan:vcan0, virtual:NAME, "
        "socketcand://127.0.0.1:PORT/telethermo, pcan:PCAN_USBBUS1, ...",
    )
    g.add_argument(
        "-i",
        "--interface",
        metavar="NAME",
        help="python-can interface (socketcan, pcan, kvaser, socketcand, virtual, ...)",
    )
    g.add_argument("-c", "--channel", metavar="CHANNEL", help="the interface's channel (vcan0, can0, ...)")
    g.add_argument("-b", "--bitrate", type=int, metavar="BIT_PER_S", help="bitrate, bit/s")
    return g
