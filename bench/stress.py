"""``python -m bench.stress [--quick] [--only CASE ...] [--list]``: the numerical-stability stress suite.

The cases live with the tests (tests/stress/cases/, run by tests/stress/test_stress_suite.py): each states
what must hold, measures, and checks it (docs/benchmarks.md). This command runs that test module with pytest
in a child process (``--stress-size quick|full --write-results``), so neither bench/ nor tests/ imports the
other, then prints the table from the results: ``bench/results/stress.json`` (machine, versions, date,
commit) with one entry per case: ``must_hold``, ``figures``, ``passed``, ``failures``. The command exits 1
if any case fails (or crashes: a crash is recorded as a failed case with its traceback).

``--quick`` shortens the long cases (1 h soak instead of 24 h, 2 h model free run, fewer fuzz examples) and
takes under 2 minutes on the 2-core VM; the full run takes several minutes.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

from bench.common import current_results_dir, print_table

ROOT = Path(__file__).resolve().parent.parent
SUITE = ROOT / "tests" / "stress" / "test_stress_suite.py"


def pytest_command(
    size: str, results_dir: Path, only: list[str] | None = None, *, collect: bool = False
) -> list[str]:
    """The pytest command that runs (or lists) the stress cases at ``size`` and writes stress.json."""
    cmd = [
        sys.executable,
        "-m",
        "pytest",
        "-q",
        "-p",
        "no:cacheprovider",
        "-m",
        "stress",
        str(SUITE),
        "--stress-size",
        size,
        "--write-results",
        str(results_dir),
    ]
    if only:
        cmd += ["--stress-only", *only]
    return cmd + (["--collect-only"] if collect else ["-rf"])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m bench.stress",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--quick", action="store_true", help="shorter runs (CI): still every case, < 2 min")
    ap.add_argument("--only", nargs="+", metavar="CASE", help="run only these cases")
    ap.add_argument("--list", action="store_true", help="list the cases, then exit")
    args = ap.parse_args(argv)
    out = current_results_dir()
    size = "quick" if args.quick else "full"
    if args.list:
        return subprocess.run(pytest_command(size, out, args.only, collect=True), cwd=ROOT).returncode
    path = out / "stress.json"
    before = path.stat().st_mtime_ns if path.exists() else None
    code = subprocess.run(pytest_command(size, out, args.only), cwd=ROOT).returncode
    if not path.exists() or path.stat().st_mtime_ns == before:
        print(f"bench.stress: pytest exited {code} and wrote no {path}", file=sys.stderr)
        return code or 2
    data = json.loads(path.read_text(encoding="utf-8"))
    results = data["cases"]
    print()
    print_table(
        ["case", "result", "wall s", "first failure"],
        [
            [
                r["name"],
                "pass" if r["passed"] else "FAIL",
                r["wall_s"],
                (r["failures"][0][:70] if r["failures"] else ""),
            ]
            for r in results
        ],
    )
    print(
        f"\n{len(results) - data['n_failed']}/{len(results)} cases passed in {data['wall_s']:.0f} s; "
        f"results in {path}"
    )
    return 1 if data["n_failed"] or code else 0


if __name__ == "__main__":
    sys.exit(main())
