"""``python -m bench.stress [--quick] [--only CASE ...] [--list]``: the numerical-stability stress suite.

Each case states what must hold, measures, and checks it (see the ``bench/stress_*.py`` modules and
docs/benchmarks.md). Results go to ``bench/results/stress.json`` (through bench.common.write_results: machine,
versions, date, commit) with one entry per case: ``must_hold``, ``figures``, ``passed``, ``failures``. The
command exits 1 if any case fails (or crashes: a crash is recorded as a failed case with its traceback).

``--quick`` shortens the long cases (1 h soak instead of 24 h, 2 h model free run, fewer fuzz examples) and
takes under 2 minutes on the 2-core VM; the full run takes several minutes.
"""
from __future__ import annotations

import argparse
import sys
import time
import traceback
from typing import Any, Callable

from bench import stress_control, stress_fuzz, stress_model, stress_rls, stress_sim, stress_slew
from bench.common import print_table, write_results

MODULES = (stress_rls, stress_model, stress_sim, stress_control, stress_slew, stress_fuzz)


def registry() -> dict[str, tuple[Callable[..., dict], dict, dict]]:
    """case name -> (function, full-run kwargs, quick kwargs), in suite order."""
    out: dict[str, tuple[Callable[..., dict], dict, dict]] = {}
    for mod in MODULES:
        out.update(mod.CASES)
    return out


def run_case(name: str, fn: Callable[..., dict], kwargs: dict) -> dict[str, Any]:
    """Run one case; a crash becomes a failed entry carrying the traceback."""
    t0 = time.perf_counter()
    try:
        res = fn(**kwargs)
    except Exception:  # noqa: BLE001 - a crashing case is a finding, not the end of the suite
        res = {"name": name, "must_hold": (fn.__doc__ or "").strip().splitlines()[0] if fn.__doc__ else "",
               "passed": False, "failures": [f"crashed: {traceback.format_exc(limit=6)}"], "figures": {},
               "notes": [], "wall_s": round(time.perf_counter() - t0, 3)}
    res["params"] = dict(kwargs)
    return res


def main(argv: list[str] | None = None) -> int:
    reg = registry()
    ap = argparse.ArgumentParser(prog="python -m bench.stress", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="shorter runs (CI): still every case, < 2 min")
    ap.add_argument("--only", nargs="+", metavar="CASE", choices=sorted(reg), help="run only these cases")
    ap.add_argument("--list", action="store_true", help="list the cases and what each must hold, then exit")
    args = ap.parse_args(argv)
    if args.list:
        for name, (fn, _, _) in reg.items():
            print(f"{name}: {(fn.__doc__ or '').strip().splitlines()[0] if fn.__doc__ else ''}")
        return 0
    names = args.only or list(reg)
    results = []
    t0 = time.perf_counter()
    for name in names:
        fn, full, quick = reg[name]
        print(f"--- {name} ...", flush=True)
        res = run_case(name, fn, quick if args.quick else full)
        results.append(res)
        print(f"    {'PASS' if res['passed'] else 'FAIL'}  {res['wall_s']:.1f} s", flush=True)
        for f in res["failures"]:
            print(f"    ! {f}", flush=True)
    total = time.perf_counter() - t0
    n_failed = sum(not r["passed"] for r in results)
    print()
    print_table(["case", "result", "wall s", "first failure"],
                [[r["name"], "pass" if r["passed"] else "FAIL", r["wall_s"], (r["failures"][0][:70] if r["failures"]
                                                                              else "")] for r in results])
    data = {"mode": "quick" if args.quick else "full", "cases": results, "n_cases": len(results),
            "n_failed": n_failed, "all_passed": n_failed == 0, "wall_s": round(total, 1)}
    for r in results:   # a case's headline figures (e.g. the surface rate around trips) at the top level
        data.update(r.pop("headline", {}))
    if args.only:
        data["only"] = list(args.only)
    path = write_results("stress", data)
    print(f"\n{len(results) - n_failed}/{len(results)} cases passed in {total:.0f} s; results in {path}")
    return 1 if n_failed else 0


if __name__ == "__main__":
    sys.exit(main())
