"""``telethermo plot FILE``: a picture of a recording, the same plot as a session's session.png.

FILE is any recording in the telethermo.offline.recording format: an offline or two-process session's
``recording.csv`` or one node's ``--record`` CSV (``master.csv``, ``slave.csv``). matplotlib (the
``plot`` extra) and numpy are imported only when the command runs.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from telethermo.cli.main import UserError
from telethermo.offline.plot import write_session_png
from telethermo.offline.recording import RecordingError, read_recording_csv

BUS_LOGS = (".log", ".asc", ".blf", ".trc")


def register(subparsers) -> None:
    p = subparsers.add_parser("plot", description="Plot a recording as session.png shows a session: temperatures, "
                                                  "estimates, flux, current, contact and safety state. FILE: a "
                                                  "session's recording.csv or a node's --record CSV (master.csv, "
                                                  "slave.csv). A damaged file is named with its line (exit 2).")
    p.add_argument("file", metavar="FILE", type=Path, help="the recording (CSV)")
    p.add_argument("-o", "--out", metavar="OUT.png", type=Path,
                   help="the picture (default: FILE with the suffix .png, e.g. master.csv -> master.png)")
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
    if src.suffix.lower() in BUS_LOGS:
        raise UserError(f"{src}: a bus log; expected a recording CSV (a session's recording.csv or a node's "
                        "--record CSV): bus logs are not plotted")
    out = out_path(args)
    try:
        import matplotlib  # noqa: F401  (the optional extra: say so before reading anything)
    except ImportError:
        raise UserError("matplotlib is not installed; install the plot extra: pip install 'telethermo[plot]'") from None
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
