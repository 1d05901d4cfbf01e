"""``telethermo bench [--quick] [--only NAME ...]``: the benchmark suite (same as ``make bench``)."""
from __future__ import annotations

import argparse


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench", description="Run every benchmark (simulator, identification, control, nodes); "
                                   "results go to bench/results/<name>.json and the table in docs/benchmarks.md.")
    p.add_argument("--quick", action="store_true", help="short runs (CI) that still measure something real")
    p.add_argument("--only", nargs="+", metavar="NAME", help="sim, identify, control, nodes")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from bench.__main__ import main

    argv = (["--quick"] if args.quick else []) + (["--only", *args.only] if args.only else [])
    return main(argv)
