"""``telethermo record``: record the bus to a python-can log (.log .asc .blf .trc) plus a decoded CSV."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from telethermo.cli import common
from telethermo.cli.main import UserError
from telethermo.cli.monitor_setup import monitor_config
from telethermo.monitor.filters import FilterError, frame_filter
from telethermo.monitor.record import (
    Recorder,
    RecordError,
    check_append,
    check_folder,
    check_log_path,
    default_csv_path,
)
from telethermo.monitor.state import Monitor


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "record",
        description="Record every frame to a python-can log file, the format chosen "
        "by the extension (.log candump, .asc Vector ASC, .blf Vector BLF, .trc PEAK trace), "
        "and the decoded frames to a CSV beside it (FILE.csv: s.blf -> s.blf.csv). "
        "Existing files are kept unless --force (replace) or --append "
        "(.log and .blf). The folder must exist. --filter keeps only some "
        "frames. Stops after --duration "
        "or --count, or on Ctrl-C (exit 0: the normal stop); the files are "
        "complete in every case.",
    )
    common.add_bus_options(p)
    p.add_argument("out", metavar="FILE", help="log file: .log, .asc, .blf or .trc")
    p.add_argument("--csv", metavar="CSV", help="decoded CSV (default: FILE.csv, e.g. s.blf.csv)")
    how = p.add_mutually_exclusive_group()
    how.add_argument("--force", action="store_true", help="replace existing files")
    how.add_argument(
        "--append",
        action="store_true",
        help="add to the existing log and CSV (.log and .blf: the formats python-can appends to)",
    )
    p.add_argument(
        "--filter",
        action="append",
        default=[],
        metavar="F",
        help="record only matching frames; repeatable, or several separated by commas: "
        "ID:MASK or ID~MASK in hex (python-can's can_filters, e.g. 180:780 every TPDO1), "
        "a node name (master), a service (nmt, sync, emcy, heartbeat, sdo, pdo), a PDO "
        "(slave.TPDO5) or an object mapped into a TPDO (cycle_counter)",
    )
    p.add_argument("--no-csv", action="store_true", help="no decoded CSV")
    p.add_argument("--duration", type=float, metavar="S", help="stop after S seconds")
    p.add_argument("--count", type=int, metavar="N", help="stop after N frames")
    p.set_defaults(func=run)


@common.failures
def run(args: argparse.Namespace) -> int:
    try:
        log = check_log_path(args.out)
    except RecordError as exc:
        raise UserError(str(exc)) from None
    if args.duration is not None and args.duration <= 0:
        raise UserError(f"--duration: expected a positive number of seconds, got {args.duration}")
    if args.count is not None and args.count <= 0:
        raise UserError(f"--count: expected a positive number of frames, got {args.count}")
    csv = None if args.no_csv else Path(args.csv) if args.csv else default_csv_path(log)
    if csv is not None and csv.resolve() == log.resolve():
        raise UserError(f"--csv {csv}: must differ from the log file")
    existing = [str(f) for f in (log, csv) if f is not None and f.exists()]
    if existing and not (args.force or args.append):
        raise UserError(
            f"{' and '.join(existing)} already exist{'s' if len(existing) == 1 else ''}; "
            "give another name, or --force to replace, or --append"
        )
    net = common.network(args)
    cfg = monitor_config(net)
    try:
        if csv is not None:
            check_folder(csv)
        if args.append:
            check_append(log, csv)
        keep = frame_filter([f for spec in args.filter for f in spec.replace(",", " ").split()], cfg)
    except (RecordError, FilterError) as exc:
        raise UserError(str(exc)) from None
    mon = Monitor(cfg)
    bus, ts = common.open_can(args, net)
    try:
        rec = Recorder(log, csv, mon, keep=keep if args.filter else None, append=args.append)
    except RecordError as exc:
        bus.shutdown()
        raise UserError(str(exc)) from None
    interrupted = False
    try:
        deadline = time.monotonic() + args.duration if args.duration else None
        print(
            f"recording {ts.describe()} to {log}" + (f" and {csv}" if csv else "") + " (Ctrl-C stops)",
            file=sys.stderr,
        )
        while True:
            if deadline is not None and time.monotonic() >= deadline:
                break
            msg = bus.recv(0.1 if deadline is None else max(0.0, min(0.1, deadline - time.monotonic())))
            if msg is not None:
                rec.on_message_received(msg)
                if args.count and rec.frames >= args.count:
                    break
    except KeyboardInterrupt:
        interrupted = True  # keep what was recorded
    finally:
        n = rec.stop()
        bus.shutdown()
    # Ctrl-C is how a recording without --duration/--count ends: a normal stop, exit 0
    print(
        f"recorded {n} frames to {log}"
        + (f" and {csv}" if csv else "")
        + (" (stopped by Ctrl-C)" if interrupted else "")
    )
    return 0
