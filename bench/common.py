"""Shared plumbing of the benchmarks: medians over repeats and result files with their provenance.

Every benchmark writes ``bench/results/<name>.json`` through :func:`write_results`, which adds the
machine, the versions, the date and the git commit, so results from different runs are comparable.
"""

from __future__ import annotations

import os
import statistics
import time
from pathlib import Path
from typing import Any, Callable

from telethermo.atomic import write_json_atomic
from telethermo.provenance import provenance

RESULTS_DIR = Path(__file__).resolve().parent / "results"
RESULTS_ENV = "TELETHERMO_BENCH_RESULTS"
"""Environment variable naming another results folder (CI's quick run writes there, not over the
committed full-run results)."""


def current_results_dir() -> Path:
    """Where results go: $TELETHERMO_BENCH_RESULTS if set, else bench/results/."""
    override = os.environ.get(RESULTS_ENV)
    return Path(override) if override else RESULTS_DIR


def write_results(name: str, data: dict[str, Any], *, results_dir: Path | None = None) -> Path:
    """Write ``data`` plus provenance to ``<results_dir>/<name>.json`` atomically; return the path."""
    out = dict(data)
    out["provenance"] = provenance()
    folder = results_dir if results_dir is not None else current_results_dir()
    return write_json_atomic(Path(folder) / f"{name}.json", out)


def median_time_s(fn: Callable[[], Any], *, repeats: int = 5, warmup: int = 1) -> float:
    """Median wall time of ``fn()`` over ``repeats`` runs after ``warmup`` runs, s."""
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def print_table(headers: list[str], rows: list[list[Any]]) -> str:
    """Print (and return) a plain-text table with right-aligned columns."""
    cells = [[h for h in headers]] + [
        [f"{c:.4g}" if isinstance(c, float) else str(c) for c in r] for r in rows
    ]
    widths = [max(len(r[i]) for r in cells) for i in range(len(headers))]
    lines = ["  ".join(c.rjust(w) for c, w in zip(r, widths)) for r in cells]
    lines.insert(1, "  ".join("-" * w for w in widths))
    text = "\n".join(lines)
    print(text)
    return text
