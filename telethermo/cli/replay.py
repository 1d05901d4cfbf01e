"""``telethermo replay LOG``: send a recorded log's frames onto a bus, at the recorded pace or faster.

What python-can's ``can.player`` does, with this project's reader and filters: the log is read by
:func:`telethermo.monitor.logread.read_log` (every format ``record`` writes, its decoded CSV too; a damaged
file stops the replay with one line naming the line or byte and how many frames were sent, exit 2) and
``--filter`` takes the names ``record --filter`` takes (nodes, services, PDOs, mapped objects by the
network file's EDS). Error frames are not sent (a controller cannot send them); remote frames are.
"""

from __future__ import annotations

import argparse
import sys

import can

from telethermo.cli import common
from telethermo.cli.main import UserError
from telethermo.cli.monitor_setup import monitor_config
from telethermo.monitor.filters import FilterError, frame_filter
from telethermo.monitor.logread import ReplayError, read_log
from telethermo.monitor.replay import paced
from telethermo.remote.errors import Failure


def register(subparsers) -> None:
    p = subparsers.add_parser("replay", description=__doc__)
    common.add_bus_options(p)
    p.add_argument(
        "log", metavar="LOG", help="the log: .log .asc .blf .trc, python-can's .csv or record's CSV"
    )
    p.add_argument(
        "--speed",
        type=float,
        default=1.0,
        metavar="X",
        help="1 = the recorded pace (default), 2 = twice as fast, 0 = as fast as possible",
    )
    p.add_argument(
        "--filter",
        action="append",
        default=[],
        metavar="F",
        help="send only matching frames; as record --filter: ID:MASK, ID~MASK (hex), a node, a "
        "service (nmt sync emcy heartbeat sdo pdo), a PDO (master.TPDO4) or a mapped object",
    )
    p.add_argument("--count", type=int, metavar="N", help="stop after sending N frames")
    p.set_defaults(func=run)


def outgoing(msg: can.Message) -> can.Message:
    """The frame to send: the recorded identifier, data and flags, no recorded channel or direction."""
    return can.Message(
        arbitration_id=msg.arbitration_id,
        is_extended_id=msg.is_extended_id,
        is_remote_frame=msg.is_remote_frame,
        dlc=msg.dlc,
        data=bytes(msg.data),
        is_fd=msg.is_fd,
        bitrate_switch=msg.bitrate_switch,
    )


@common.failures
def run(args: argparse.Namespace) -> int:
    if args.speed < 0:
        raise UserError(f"--speed: expected a number >= 0, got {args.speed}")
    if args.count is not None and args.count <= 0:
        raise UserError(f"--count: expected a positive number of frames, got {args.count}")
    net = common.network(args)
    try:
        keep = frame_filter(
            [f for spec in args.filter for f in spec.replace(",", " ").split()], monitor_config(net)
        )
        frames = read_log(args.log)
    except (FilterError, ReplayError) as exc:
        raise UserError(str(exc)) from None
    bus, ts = common.open_can(args, net)
    sent = 0
    try:
        print(
            f"replaying {args.log} onto {ts.describe()} at "
            f"{'full speed' if args.speed == 0 else f'x{args.speed:g}'} (Ctrl-C stops)",
            file=sys.stderr,
        )
        wanted = (m for m in frames if not m.is_error_frame and keep(m))
        for msg in paced(wanted, speed=args.speed):
            try:
                bus.send(outgoing(msg))
            except can.CanError as exc:
                raise Failure(
                    f"{ts.describe()}: frame {sent + 1} (0x{msg.arbitration_id:03X}) not sent "
                    f"({exc}); {sent} frames were sent"
                ) from None
            sent += 1
            if args.count and sent >= args.count:
                break
    except ReplayError as exc:
        raise UserError(f"{exc}; {sent} frames were sent") from None
    finally:
        bus.shutdown()
    print(f"replayed {sent} frames of {args.log} onto {ts.describe()}")
    return 0
