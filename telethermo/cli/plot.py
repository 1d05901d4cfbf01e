"""``telethermo plot FILE``: a picture of a recording, the same plot as a session's session.png.

FILE is any recording in the telethermo.recording.format format (an offline or two-process session's
``recording.csv`` or one node's ``--record`` CSV: ``master.csv``, ``slave.csv``), or a bus log
(``telethermo record`` / python-can: .log, .asc, .blf, .trc, or the decoded CSV ``telethermo record`` writes
beside its log, ``s.blf.csv``): its PDO values decoded by the EDS mappings
of the network file's nodes, one panel per unit, EMCYs marked. matplotlib (the ``plot`` extra) is
imported only when the command runs.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from telethermo.atomic import write_bytes_atomic
from telethermo.cli import common
from telethermo.cli.main import UserError
from telethermo.cli.monitor_setup import monitor_config
from telethermo.monitor.busplot import decode_bus_log, plot_bus_log_png
from telethermo.monitor.logread import ReplayError, is_record_csv, read_log
from telethermo.offline.plot import write_session_png
from telethermo.recording.format import RecordingError, read_recording_csv

BUS_LOGS = (".log", ".asc", ".blf", ".trc")


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "plot",
        description="Plot a recording as session.png shows a session: temperatures, "
        "estimates, flux, current, contact and safety state. FILE: a "
        "session's recording.csv or a node's --record CSV (master.csv, "
        "slave.csv), or a bus log (.log/.asc/.blf/.trc, or the "
        "CSV `telethermo record` writes beside it: the PDO "
        "values by the EDS mappings, one panel per unit, codes "
        "and counters apart, EMCYs marked). A damaged file is "
        "named with its line or byte (exit 2).",
    )
    p.add_argument("file", metavar="FILE", type=Path, help="the recording (CSV) or a bus log")
    p.add_argument(
        "--network",
        metavar="FILE",
        help="bus log: the network file whose nodes' EDS decode the PDOs (default: the shipped one)",
    )
    p.add_argument(
        "-o",
        "--out",
        metavar="OUT.png",
        type=Path,
        help="the picture (default: FILE with the suffix .png, e.g. master.csv -> master.png)",
    )
    p.set_defaults(func=run)


def out_path(args: argparse.Namespace) -> Path:
    out = args.out if args.out is not None else args.file.with_suffix(".png")
    if out.suffix.lower() != ".png":
        raise UserError(f"-o {out}: expected a .png file name")
    if out.resolve() == args.file.resolve():
        raise UserError(f"-o {out}: is the recording itself; give another file name")
    return out


def run(args: argparse.Namespace) -> int:
    src: Path = args.file
    out = out_path(args)
    try:
        import matplotlib  # noqa: F401  (the optional extra: say so before reading anything)
    except ImportError:
        raise UserError(
            "matplotlib is not installed; install the plot extra: pip install 'telethermo[plot]'"
        ) from None
    if src.suffix.lower() in BUS_LOGS or (src.suffix.lower() == ".csv" and is_record_csv(src)):
        return plot_bus_log(args, src, out)
    try:
        rec = read_recording_csv(src)
    except RecordingError as exc:
        raise UserError(f"{exc}; expected a session's recording.csv or a node's --record CSV") from None
    if len(rec) == 0:
        raise UserError(f"{src}: no rows after the header (line 3); nothing to plot")
    try:
        path = write_session_png(out, rec)
    except ValueError as exc:
        raise UserError(f"{src}: {exc}") from None
    except OSError as exc:
        raise UserError(f"{out}: cannot write the picture ({exc.strerror or exc})") from None
    print(f"{path}: {len(rec)} rows, {rec.col('t_s')[-1] - rec.col('t_s')[0]:.2f} s")
    return 0


def plot_bus_log(args: argparse.Namespace, src: Path, out: Path) -> int:
    """A bus log's PDO values (by the network file's EDS mappings) and EMCYs, as a PNG."""
    cfg = monitor_config(common.network(args))
    ods = {nid: n.od for nid, n in cfg.nodes.items()}
    names = {nid: n.name for nid, n in cfg.nodes.items()}
    try:
        data = decode_bus_log(read_log(src), ods, names)
    except ReplayError as exc:
        raise UserError(str(exc)) from None
    try:
        png = plot_bus_log_png(data, f"{src.name}: {data.frames} frames, {data.pdo_frames} PDOs decoded")
    except ValueError as exc:
        raise UserError(f"{src}: {exc}") from None
    try:
        path = write_bytes_atomic(out, png)
    except OSError as exc:
        raise UserError(f"{out}: cannot write the picture ({exc.strerror or exc})") from None
    print(f"{path}: {data.frames} frames, {len(data.series)} series, {len(data.emcys)} EMCY")
    return 0
