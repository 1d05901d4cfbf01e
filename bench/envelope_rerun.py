"""The skeleton the envelope matrix's partial re-runs share (:mod:`bench.envelope_controller`,
:mod:`bench.envelope_pads`): read ``bench/results/envelope.json``, run one function on each scored condition
and the base scene on a process pool, keep the rows that could not be scored (listed again, never dropped)
and the optimal-current bounds, recompute the summary with :mod:`bench.envelope_bench`'s functions, and
print what moved against the run it replaces.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from typing import Any

from bench.common import current_results_dir
from bench.envelope_bench import bound_summary, summarise

#: the summary keys compared against the run they replace
COMPARED = (
    "envelope_oscillating_conditions",
    "envelope_session_long_cuts",
    "envelope_unexpected_trips",
    "envelope_beats_best_pad_fraction",
    "envelope_cue_order_kept_fraction",
    "envelope_median_ratio_to_bound",
    "envelope_captured_fraction_median",
    "base_headline_C",
    "base_pre_contact_C",
    "base_oscillation_ratio",
)
BOUND_KEYS = ("index", "bound_headline_C", "replay_max_diff_C")

Row = dict[str, Any]


@dataclass
class Rerun:
    """One partial re-run: the file it replaces (``old``), the new rows of the scored conditions
    (``scored``, in the file's order), the unscored rows kept (``errors``), the base scene's new row, the
    summary keys recomputed from them (``summary``) and the wall time, s."""

    old: dict[str, Any]
    scored: list[Row]
    errors: list[Row]
    base: Row
    summary: dict[str, Any]
    wall_s: float

    @property
    def old_scored(self) -> list[Row]:
        """The replaced file's scored rows, in the order of ``scored``."""
        return [r for r in self.old["conditions"] if "error" not in r]

    @property
    def rows(self) -> list[Row]:
        """Every row of the new file: the scored ones, then the unscored ones."""
        return self.scored + self.errors


def rerun_matrix(fn: Callable[[Row], Row], workers: int) -> Rerun:
    """Run ``fn`` (a picklable function of one row of the existing envelope.json) on every scored condition
    and the base scene with ``workers`` processes; the summary keys are recomputed from the new rows and the
    kept bounds."""
    old = json.loads((current_results_dir() / "envelope.json").read_text(encoding="utf-8"))
    errors = [r for r in old["conditions"] if "error" in r]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=workers) as ex:
        fut_base = ex.submit(fn, old["base"])
        scored = list(ex.map(fn, [r for r in old["conditions"] if "error" not in r]))
        base = fut_base.result()
    wall = time.perf_counter() - t0
    bounds = [{k: b[k] for k in BOUND_KEYS} for b in old["bound_conditions"]]
    summary = {**summarise(scored + errors, base), **bound_summary(scored, bounds, base)}
    return Rerun(old, scored, errors, base, summary, wall)


def print_change(old: dict[str, Any], new: dict[str, Any]) -> None:
    """The compared summary keys, before -> after."""
    for k in COMPARED:
        print(f"{k:40s} {old.get(k)!s:>22.22} -> {new[k]!s:.22}")
