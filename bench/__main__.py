"""``python -m bench [--quick] [--only NAME ...]``: run every benchmark, write bench/results/*.json,
then refresh the generated table in docs/benchmarks.md.

Each benchmark is a module ``bench.<name>_bench`` exposing ``run(quick: bool) -> dict`` that prints
its own table and writes ``bench/results/<name>.json`` (through bench.common.write_results).
"""
from __future__ import annotations

import argparse
import importlib
import json
import sys
import time
import traceback

import os

from bench.common import RESULTS_DIR, RESULTS_ENV, current_results_dir
from bench.report import refresh_docs, write_plots

SUITE = ["sim", "identify", "control", "transparency", "nodes", "identify_live", "cli", "rendering", "monitor", "envelope"]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench", description=__doc__)
    ap.add_argument("--quick", action="store_true", help="short runs for CI that still measure something real")
    ap.add_argument("--only", nargs="+", choices=SUITE, help="run only these benchmarks")
    ap.add_argument("--results-dir", help="write the result files here instead of bench/results/ "
                                          "(docs/benchmarks.md is then left alone)")
    args = ap.parse_args(argv)
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
