"""One stress case's verdict: what must hold, the measured figures, and the checks that failed.

A case function builds a :class:`Case`, measures, calls :meth:`Case.require` for every fact that must
hold (each with the measured value in its text) and returns ``case.result()``. The whole suite
(tests/stress/test_stress_suite.py, which ``python -m bench.stress`` runs) and the fast subset (the other
tests in tests/stress) call the same functions, with smaller sizes in the subset.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np


def _plain(v: Any) -> Any:
    """JSON-safe copy of a figure (numpy scalars to Python; non-finite floats as strings)."""
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, np.ndarray):
        return [_plain(x) for x in v.tolist()]
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        f = float(v)
        return f if math.isfinite(f) else str(f)
    return v


class Case:
    """Collects the figures and failed requirements of one stress case.

    Args:
        name: short identifier (``group_what``), unique in the suite.
        must_hold: one sentence: what must hold (the claim the case checks).
    """

    def __init__(self, name: str, must_hold: str) -> None:
        self.name, self.must_hold = name, must_hold
        self.figures: dict[str, Any] = {}
        self.failures: list[str] = []
        self.notes: list[str] = []
        self._t0 = time.perf_counter()

    def fig(self, **figures: Any) -> None:
        """Record measured figures (units in the key names)."""
        self.figures.update(figures)

    def require(self, ok: bool, what: str) -> bool:
        """A fact that must hold; ``what`` states it with the measured value. Returns ``ok``."""
        if not bool(ok):
            self.failures.append(what)
        return bool(ok)

    def note(self, text: str) -> None:
        """A remark for the reader (a limit of the case, a finding that is not a failure)."""
        self.notes.append(text)

    @property
    def passed(self) -> bool:
        return not self.failures

    def result(self) -> dict[str, Any]:
        """The case's entry in bench/results/stress.json."""
        return {
            "name": self.name,
            "must_hold": self.must_hold,
            "passed": self.passed,
            "failures": list(self.failures),
            "figures": _plain(self.figures),
            "notes": list(self.notes),
            "wall_s": round(time.perf_counter() - self._t0, 3),
        }


def assert_passed(result: dict[str, Any]) -> None:
    """For the tests: fail with the case's failed requirements and figures."""
    assert result["passed"], (
        f"stress case {result['name']} failed: {result['failures']}; figures {result['figures']}"
    )
