"""CiA 301 conformance of the live node pair (real-time, over the hub) through canopen's RemoteNode /
SdoClient / NmtMaster built from the shipped EDS files and raw frames only (bench/conformance_checks.py).
One pair for the module, the checks in their order: each disturbing check ends by proving the pair
recovered. The same checks write bench/results/conformance.json (python -m bench.conformance_bench)."""
from __future__ import annotations

import pytest

from bench.conformance_checks import run_check
from bench.conformance_corners import SUITE as CHECKS
from bench.conformance_lab import live_pair


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    with live_pair(tmp_path_factory.mktemp("conformance"), timing="realtime") as lab:
        yield lab


@pytest.mark.slow
@pytest.mark.parametrize("check", CHECKS, ids=[c.name for c in CHECKS])
def test_cia301(lab, check):
    res = run_check(check, lab)
    assert res["result"] == "PASS", f"{check.name} ({check.clause}): {res['detail']}"
