"""``telethermo bench [--quick] [--only NAME ...]``: the benchmark suite (same as ``make bench``).

The suite is its own program, ``python -m bench``, which this command runs as a child process (same
interpreter, same arguments, its exit code): the benchmarks sit above every layer of telethermo (they
time the simulator, the nodes, the CLI itself), so the CLI must not import them.
"""

from __future__ import annotations

import argparse
import subprocess
import sys


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "bench",
        description="Run every benchmark (simulator, identification, control, nodes); "
        "results go to bench/results/<name>.json and the table in docs/benchmarks.md.",
    )
    p.add_argument("--quick", action="store_true", help="short runs (CI) that still measure something real")
    p.add_argument("--only", nargs="+", metavar="NAME", help="sim, identify, control, nodes")
    p.set_defaults(func=run)


def bench_argv(args: argparse.Namespace) -> list[str]:
    """The command line of the suite for ``args``."""
    return (
        [sys.executable, "-m", "bench"]
        + (["--quick"] if args.quick else [])
        + (["--only", *args.only] if args.only else [])
    )


def run(args: argparse.Namespace) -> int:
    return subprocess.call(bench_argv(args))
