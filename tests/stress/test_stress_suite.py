"""The whole stress suite, every case at its quick or full size (docs/benchmarks.md, "stress"): runs when
pytest is given ``--stress-size quick|full`` (``python -m bench.stress`` does, with ``--write-results`` for
bench/results/stress.json); a plain run of the suite skips it (the other tests in tests/stress run the same
case functions at smaller sizes). A crashing case is a failed entry carrying its traceback."""

from __future__ import annotations

from typing import Any

import pytest

from tests.stress.cases import registry, run_case

pytestmark = pytest.mark.stress
CASES = registry()


def stress_document(
    entries: list[dict[str, Any]], wall_s: float, *, size: str, only: list[str] | None
) -> dict[str, Any]:
    """bench/results/stress.json: the cases, their count, the failed count and each case's headline."""
    cases = [dict(e) for e in entries]
    n_failed = sum(not r["passed"] for r in cases)
    data: dict[str, Any] = {
        "mode": size,
        "cases": cases,
        "n_cases": len(cases),
        "n_failed": n_failed,
        "all_passed": n_failed == 0,
        "wall_s": round(wall_s, 1),
    }
    for r in cases:  # a case's headline figures (e.g. the surface rate around trips) at the top level
        data.update(r.pop("headline", {}))
    if only:
        data["only"] = list(only)
    return data


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    if "case_name" in metafunc.fixturenames:
        only = metafunc.config.getoption("--stress-only")
        unknown = sorted(set(only or ()) - set(CASES))
        if unknown:
            raise pytest.UsageError(f"--stress-only: no such case {unknown}; the cases: {sorted(CASES)}")
        names = [n for n in CASES if not only or n in only]
        metafunc.parametrize("case_name", names)


def test_stress_case(case_name, request, results_writer):
    size = request.config.getoption("--stress-size")
    if size is None:
        pytest.skip("the full stress suite runs with --stress-size quick|full (python -m bench.stress)")
    fn, full, quick = CASES[case_name]
    res = run_case(case_name, fn, quick if size == "quick" else full)
    only = request.config.getoption("--stress-only")
    results_writer.add("stress", res, lambda e, w: stress_document(e, w, size=size, only=only))
    assert res["passed"], f"stress case {case_name} failed: {res['failures']}; figures {res['figures']}"
