"""``python -m bench [--quick] [--only NAME ...]``: run every benchmark, write bench/results/*.json,
then refresh the generated table in docs/benchmarks.md. ``python -m bench --check [--results-dir DIR]``
runs nothing: it prints, per target of bench/targets.py, met / short / missing from the result files, and
exits 1 when any is short.

Each benchmark is a module ``bench.<name>_bench`` exposing ``run(quick: bool) -> dict`` that prints
its own table and writes ``bench/results/<name>.json`` (through bench.common.write_results).
"""

from __future__ import annotations

import argparse
import importlib
import sys
import time
import traceback

import os
from pathlib import Path

from bench.common import RESULTS_DIR, RESULTS_ENV, current_results_dir
from bench.report import refresh_docs, write_plots
from bench.targets import check, check_table

SUITE = [
    "sim",
    "identify",
    "control",
    "transparency",
    "nodes",
    "identify_live",
    "cli",
    "rendering",
    "monitor",
    "envelope",
    "envelope_heldout",
]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench", description=__doc__)
    ap.add_argument(
        "--quick", action="store_true", help="short runs for CI that still measure something real"
    )
    ap.add_argument("--only", nargs="+", choices=SUITE, help="run only these benchmarks")
    ap.add_argument(
        "--results-dir",
        help="write the result files here instead of bench/results/ (docs/benchmarks.md is then left alone)",
    )
    ap.add_argument(
        "--check",
        action="store_true",
        help="run nothing: per target, met / short / missing from the result files; exit 1 when any is short",
    )
    args = ap.parse_args(argv)
    if args.check:
        rows = check(Path(args.results_dir) if args.results_dir else RESULTS_DIR)
        print(check_table(rows))
        n = {v: sum(r[1] == v for r in rows) for v in ("met", "short", "missing")}
        print(f"\n{n['met']} met, {n['short']} short, {n['missing']} missing (of {len(rows)} targets)")
        return 1 if n["short"] else 0
    if args.results_dir:
        os.makedirs(args.results_dir, exist_ok=True)
        os.environ[RESULTS_ENV] = args.results_dir
    failed = []
    for name in args.only or SUITE:
        print(f"\n===== bench {name} ({'quick' if args.quick else 'full'}) =====", flush=True)
        t0 = time.perf_counter()
        try:
            mod = importlib.import_module(f"bench.{name}_bench")
            mod.run(quick=args.quick)
        except Exception:  # one broken benchmark must not hide the others' results
            traceback.print_exc()
            failed.append(name)
        print(f"----- bench {name}: {time.perf_counter() - t0:.1f} s", flush=True)
    out = current_results_dir()
    for png in write_plots(out):
        print(f"plot: {png}")
    if out.resolve() == RESULTS_DIR.resolve():
        print(f"\nresults in {out}; table refreshed in {refresh_docs(out)}")
    else:
        print(f"\nresults in {out} (docs/benchmarks.md left alone)")
    if failed:
        print(f"FAILED benchmarks: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
