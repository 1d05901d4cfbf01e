"""Calibrate the slave's material classifier on simulated reference touches (issue 15).

``python -m bench.material_calibrate [--n 200000] [--dense 30000] [--jobs 2] [--touches CACHE] [--validate]
[--hidden 512] [--layers 3] [--epochs 40] [--nets 1] [--out telethermo/data/material_classifier.npz]``

The procedure (reference touches, whitening, training, ``--validate``, ``--touches``) is
telethermo/offline/material_calibration.py's :func:`calibrate`; its docstring describes it.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

from telethermo.control.material_calib import DEFAULT_CALIBRATION
from telethermo.control.material_train import TrainSettings
from telethermo.offline.material_calibration import calibrate


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m bench.material_calibrate",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--n", type=int, default=200000, help="reference touches (default 200000)")
    ap.add_argument(
        "--dense",
        type=int,
        default=30000,
        help="extra reference touches of ceramic and the metals at 2-6 N (default 30000)",
    )
    ap.add_argument("--jobs", type=int, default=2, help="simulating processes (default 2)")
    ap.add_argument(
        "--touches",
        type=Path,
        default=None,
        help="cache of the simulated reference touches (read when it holds the same draws, else written)",
    )
    ap.add_argument(
        "--validate", action="store_true", help="first train on four fifths and score the fifth left out"
    )
    d = TrainSettings()
    ap.add_argument(
        "--hidden", type=int, default=d.hidden, help=f"units per hidden layer (default {d.hidden})"
    )
    ap.add_argument("--layers", type=int, default=d.layers, help=f"hidden layers (default {d.layers})")
    ap.add_argument("--epochs", type=int, default=d.epochs, help=f"training passes (default {d.epochs})")
    ap.add_argument("--nets", type=int, default=d.n_nets, help=f"ensemble members (default {d.n_nets})")
    ap.add_argument("--out", type=Path, default=DEFAULT_CALIBRATION, help="calibration file to write")
    args = ap.parse_args(argv)
    settings = replace(d, hidden=args.hidden, layers=args.layers, epochs=args.epochs, n_nets=args.nets)
    calibrate(args.n, args.out, args.dense, args.jobs, settings, args.touches, args.validate)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
