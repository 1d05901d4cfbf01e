"""CiA 301 conformance of the live node pair (over the hub) through canopen's RemoteNode / SdoClient /
NmtMaster built from the shipped EDS files and raw frames only (tests/conformance/checks.py). One pair per
timing mode (``--conformance-timing``, default real time), the checks in their order: each disturbing
check ends by proving the pair recovered. With ``--write-results DIR`` the checks' verdicts go to
DIR/conformance.json (``python -m bench.conformance_bench`` runs both timing modes so)."""

from __future__ import annotations

import contextlib
from typing import Any

import pytest

from tests.conformance.checks import run_check
from tests.conformance.corners import SUITE as CHECKS
from tests.conformance.lab import live_pair

pytestmark = [pytest.mark.conformance, pytest.mark.slow]
CLIENT = (
    "canopen RemoteNode/SdoClient/NmtMaster from bus_config/*.eds + raw python-can frames (socketcand hub)"
)


def conformance_document(
    entries: list[dict[str, Any]], wall_s: float, *, timings: list[str]
) -> dict[str, Any]:
    """bench/results/conformance.json: every check's verdict per timing mode, and the failed count."""
    return {
        "n_checks": len(entries),
        "n_fail": sum(r["result"] != "PASS" for r in entries),
        "timings": list(timings),
        "client": CLIENT,
        "wall_s": round(wall_s, 1),
        "checks": list(entries),
    }


def _timings(config: pytest.Config) -> list[str]:
    return list(config.getoption("--conformance-timing") or ["realtime"])


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    if "timing" in metafunc.fixturenames:
        metafunc.parametrize("timing", _timings(metafunc.config), scope="module")


@pytest.fixture(scope="module")
def lab(timing, tmp_path_factory):
    """The live pair, or the reason it did not start (every check then counts as an ERROR)."""
    with contextlib.ExitStack() as stack:
        try:
            pair = stack.enter_context(
                live_pair(tmp_path_factory.mktemp(f"conformance-{timing}"), timing=timing)
            )
        except Exception as exc:  # noqa: BLE001 - the pair's failure is each check's verdict
            pair = f"pair failed: {type(exc).__name__}: {exc}"
        yield pair


@pytest.mark.parametrize("check", CHECKS, ids=[c.name for c in CHECKS])
def test_cia301(lab, timing, check, request, results_writer):
    if isinstance(lab, str):
        res = {"name": check.name, "clause": check.clause, "result": "ERROR", "detail": lab}
    else:
        res = run_check(check, lab)
    res["timing"] = timing
    results_writer.add(
        "conformance", res, lambda e, w: conformance_document(e, w, timings=_timings(request.config))
    )
    assert res["result"] == "PASS", f"{check.name} ({check.clause}) [{timing}]: {res['detail']}"
