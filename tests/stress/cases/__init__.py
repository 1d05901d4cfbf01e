"""The numerical-stability stress cases (docs/benchmarks.md, "stress"): each module's ``CASES`` maps a case
name to ``(function, full-run kwargs, quick kwargs)``; a case function returns its verdict
(:class:`tests.stress.cases.case.Case`). tests/stress/test_stress_suite.py runs them (``python -m
bench.stress``); the other tests in tests/stress call the same functions with smaller sizes."""

from __future__ import annotations

import time
import traceback
from typing import Any, Callable

from tests.stress.cases import control, fuzz, model, rls, sim, slew

MODULES = (rls, model, sim, control, slew, fuzz)


def registry() -> dict[str, tuple[Callable[..., dict], dict, dict]]:
    """case name -> (function, full-run kwargs, quick kwargs), in suite order."""
    out: dict[str, tuple[Callable[..., dict], dict, dict]] = {}
    for mod in MODULES:
        out.update(mod.CASES)
    return out


def must_hold(fn: Callable[..., dict]) -> str:
    """The first line of a case function's docstring: what the case checks."""
    return (fn.__doc__ or "").strip().splitlines()[0] if fn.__doc__ else ""


def run_case(name: str, fn: Callable[..., dict], kwargs: dict) -> dict[str, Any]:
    """Run one case; a crash becomes a failed entry carrying the traceback."""
    t0 = time.perf_counter()
    try:
        res = fn(**kwargs)
    except Exception:  # noqa: BLE001 - a crashing case is a finding, not the end of the suite
        res = {
            "name": name,
            "must_hold": must_hold(fn),
            "passed": False,
            "failures": [f"crashed: {traceback.format_exc(limit=6)}"],
            "figures": {},
            "notes": [],
            "wall_s": round(time.perf_counter() - t0, 3),
        }
    res["params"] = dict(kwargs)
    return res
