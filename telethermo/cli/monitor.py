"""``telethermo monitor``: the CANopen bus monitor, live on any python-can bus or replaying a log."""

from __future__ import annotations

import argparse
import curses
import sys
import time
from typing import Iterable, Iterator

import can

from telethermo.cli import common
from telethermo.cli.main import UserError
from telethermo.cli.monitor_setup import monitor_config
from telethermo.monitor.replay import Pacer, ReplayError, live, paced, read_log
from telethermo.monitor.run import bus_state_poller, run_curses, run_lines
from telethermo.monitor.state import Monitor
from telethermo.monitor.view import ViewState


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "monitor",
        description="Decode the CANopen bus: NMT states, heartbeats against the consumer time, EMCY, SDO "
        "transfers (one state machine per node), PDOs by the EDS mapping and by remapping seen on "
        "the bus, SYNC period/jitter, bus load, events. Curses view by default; --json or --lines "
        "for scripts. Keys in the view: ? for help; r raw frame list, l frame log, e event log, "
        "i incident hints, t temperatures, arrows/PgUp/Home/End scroll.",
    )
    common.add_bus_options(p)
    p.add_argument(
        "--replay",
        metavar="LOG",
        help="replay a python-can log (.log .asc .blf .csv .trc) or the "
        "decoded CSV of telethermo record, instead of a live bus",
    )
    p.add_argument(
        "--speed",
        type=float,
        default=None,
        metavar="X",
        help="replay speed: 1 = as recorded, 0 = as fast as possible "
        "(default 1 in the view, 0 with --json/--lines)",
    )
    out = p.add_mutually_exclusive_group()
    out.add_argument("--json", action="store_true", help="JSON lines (frames, events, status) on stdout")
    out.add_argument("--lines", action="store_true", help="plain text lines on stdout")
    p.add_argument("--no-frames", action="store_true", help="with --json/--lines: events and status only")
    p.add_argument(
        "--status-every",
        type=float,
        default=1.0,
        metavar="S",
        help="with --json/--lines: a status line every S s of bus time (0: only at the end)",
    )
    p.add_argument("--duration", type=float, metavar="S", help="stop after S seconds (live)")
    p.add_argument("--count", type=int, metavar="N", help="stop after N frames")
    p.add_argument(
        "--eds",
        action="append",
        default=[],
        metavar="NODE=FILE",
        help="decode a further node (not in the network file) by its EDS: PDOs by mapping, SDO by "
        "object name; repeatable, e.g. --eds 5=arm.eds",
    )
    p.add_argument(
        "--rig-config",
        action="append",
        default=[],
        metavar="RIG.toml",
        help="an I/O rig's file (as the node's --rig-config): its CiA 401 modules are named and their PDOs "
        "decoded by their EDS, and its controller is expected to beat at the period it lowers its "
        "heartbeat to; repeatable (one per side)",
    )
    p.add_argument(
        "--sync-period",
        type=float,
        metavar="S",
        help="nominal SYNC period for late cycles, s "
        "(default: the network file's [sync] period_s, in lockstep too)",
    )
    p.set_defaults(func=run)


@common.failures
def _check_args(args: argparse.Namespace) -> None:
    if args.speed is not None and args.speed < 0:
        raise UserError(f"--speed: expected a number >= 0, got {args.speed}")
    if args.duration is not None and args.duration <= 0:
        raise UserError(f"--duration: expected a positive number of seconds, got {args.duration}")
    if args.count is not None and args.count <= 0:
        raise UserError(f"--count: expected a positive number of frames, got {args.count}")


def _limited(source: Iterable[can.Message | None], count: int | None) -> Iterator[can.Message | None]:
    """``source`` up to its ``count``-th frame (the idle Nones pass)."""
    n = 0
    for m in source:
        if m is not None:
            n += 1
        yield m
        if count and n >= count:
            return


def run(args: argparse.Namespace) -> int:
    _check_args(args)
    net = common.network(args)
    mon = Monitor(
        monitor_config(
            net,
            bitrate=args.bitrate,
            sync_period_s=args.sync_period,
            extra_eds=args.eds,
            rig_configs=args.rig_config,
        )
    )
    scripted = args.json or args.lines
    bus = None
    deadline = time.monotonic() + args.duration if args.duration else None
    until = (lambda: time.monotonic() >= deadline) if deadline else None
    try:
        if args.replay:
            try:
                msgs = read_log(args.replay)
            except ReplayError as exc:
                raise UserError(str(exc)) from None
            speed = args.speed if args.speed is not None else (0.0 if scripted else 1.0)
            source, desc, mode, now = (
                msgs,
                args.replay,
                f"REPLAY x{speed:g}" if speed else "REPLAY (max speed)",
                None,
            )
        else:
            bus, ts = common.open_can(args, net)
            source, desc, mode, now = live(bus), ts.describe(), "LIVE", time.time
            speed = 0.0
        poll = bus_state_poller(bus) if bus is not None else None
        if bus is None:
            mon.set_bus_state(None, "a log replay")
        try:
            if scripted:
                src = paced(source, speed=speed) if args.replay else source
                run_lines(
                    src,
                    mon,
                    sys.stdout,
                    as_json=args.json,
                    frames=not args.no_frames,
                    status_every_s=args.status_every,
                    max_frames=args.count,
                    until=until,
                    now=now,
                    poll=poll,
                )
            else:
                if not sys.stdout.isatty():
                    raise UserError("the view needs a terminal; use --json or --lines for scripts")
                vs = ViewState(source=desc, mode=mode)
                curses.wrapper(
                    run_curses,
                    _limited(source, args.count),
                    mon,
                    vs,
                    pacer=Pacer(speed) if args.replay else None,
                    now=now,
                    until=until,
                    poll=poll,
                )
                if vs.error:
                    raise ReplayError(vs.error)  # shown in the view until q; the exit says it too
        except ReplayError as exc:  # a damaged log is bad input (exit 2), as in `plot`
            raise UserError(str(exc)) from None
    finally:
        if bus is not None:
            bus.shutdown()
    return 0
