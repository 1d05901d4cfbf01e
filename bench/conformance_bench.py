"""CiA 301 conformance of the live node pair, through an independent client (canopen's RemoteNode /
SdoClient / NmtMaster from the shipped EDS files and raw frames; bench/conformance_checks.py, the same
checks as tests/conformance/).

    python -m bench.conformance_bench [--quick] [--timing realtime lockstep]

Starts the master and slave programs over a fresh loopback hub for each timing mode (default both; quick:
real time only), runs every check in order and writes bench/results/conformance.json: ``n_checks``,
``n_fail`` (FAIL or ERROR) and ``checks`` (name, clause, timing, result, detail). Exit code 1 if a check
failed.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from bench.common import print_table, write_results
from bench.conformance_checks import run_check
from bench.conformance_corners import SUITE as CHECKS
from bench.conformance_lab import live_pair

TIMINGS = ("realtime", "lockstep")


def run(quick: bool = False, timings: tuple[str, ...] | None = None) -> dict[str, Any]:
    timings = timings or (("realtime",) if quick else TIMINGS)
    results: list[dict] = []
    t0 = time.perf_counter()
    for timing in timings:
        with tempfile.TemporaryDirectory(prefix=f"conformance-{timing}-") as tmp:
            try:
                with live_pair(Path(tmp), timing=timing) as lab:
                    for check in CHECKS:
                        res = run_check(check, lab)
                        res["timing"] = timing
                        results.append(res)
                        print(f"  {timing:9s} {res['result']:5s} {check.name}: {res['detail']}", flush=True)
            except Exception as exc:   # the pair itself failed: every check not run counts as an error
                done = {r["name"] for r in results if r["timing"] == timing}
                for check in CHECKS:
                    if check.name not in done:
                        results.append({"name": check.name, "clause": check.clause, "timing": timing,
                                        "result": "ERROR", "detail": f"pair failed: {type(exc).__name__}: {exc}"})
    n_fail = sum(r["result"] != "PASS" for r in results)
    data = {
        "n_checks": len(results),
        "n_fail": n_fail,
        "timings": list(timings),
        "client": "canopen RemoteNode/SdoClient/NmtMaster from bus_config/*.eds + raw python-can frames (socketcand hub)",
        "wall_s": round(time.perf_counter() - t0, 1),
        "checks": results,
    }
    write_results("conformance", data)
    print_table(["timing", "check", "result"], [[r["timing"], r["name"], r["result"]] for r in results])
    print(f"conformance: {len(results)} checks, {n_fail} failed")
    return data


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.conformance_bench", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="real time only")
    ap.add_argument("--timing", nargs="+", choices=TIMINGS, help="timing modes to run (default: both)")
    args = ap.parse_args(argv)
    data = run(quick=args.quick, timings=tuple(args.timing) if args.timing else None)
    return 1 if data["n_fail"] else 0


if __name__ == "__main__":
    sys.exit(main())
