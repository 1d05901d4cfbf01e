"""CiA 301 conformance of the live node pair, through an independent client (canopen's RemoteNode /
SdoClient / NmtMaster from the shipped EDS files and raw frames; the checks are tests/conformance/).

    python -m bench.conformance_bench [--quick] [--timing realtime lockstep]

Runs tests/conformance/ with pytest in a child process (``--conformance-timing ... --write-results``), so
neither bench/ nor tests/ imports the other: the master and slave programs over a fresh loopback hub for
each timing mode (default both; quick: real time only), every check in order, and
bench/results/conformance.json: ``n_checks``, ``n_fail`` (FAIL or ERROR) and ``checks`` (name, clause,
timing, result, detail). Exit code 1 if a check failed.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

from bench.common import current_results_dir, print_table

ROOT = Path(__file__).resolve().parent.parent
TESTS = ROOT / "tests" / "conformance"
TIMINGS = ("realtime", "lockstep")


def run(quick: bool = False, timings: tuple[str, ...] | None = None) -> dict[str, Any]:
    timings = timings or (("realtime",) if quick else TIMINGS)
    path = current_results_dir() / "conformance.json"
    before = path.stat().st_mtime_ns if path.exists() else None
    cmd = [
        sys.executable,
        "-m",
        "pytest",
        "-q",
        "-p",
        "no:cacheprovider",
        "-m",
        "conformance",
        str(TESTS),
        "--conformance-timing",
        *timings,
        "--write-results",
        str(path.parent),
        "-rf",
    ]
    code = subprocess.run(cmd, cwd=ROOT).returncode
    if not path.exists() or path.stat().st_mtime_ns == before:
        raise RuntimeError(f"conformance: pytest exited {code} and wrote no {path}")
    data = json.loads(path.read_text(encoding="utf-8"))
    results = data["checks"]
    print_table(["timing", "check", "result"], [[r["timing"], r["name"], r["result"]] for r in results])
    print(f"conformance: {len(results)} checks, {data['n_fail']} failed")
    return data


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m bench.conformance_bench",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--quick", action="store_true", help="real time only")
    ap.add_argument("--timing", nargs="+", choices=TIMINGS, help="timing modes to run (default: both)")
    args = ap.parse_args(argv)
    data = run(quick=args.quick, timings=tuple(args.timing) if args.timing else None)
    return 1 if data["n_fail"] else 0


if __name__ == "__main__":
    sys.exit(main())
