"""The benchmarks' targets as data, and ``python -m bench --check``: per key met / short / missing.

One row per target: the result file (``bench/results/<file>.json``), the key, the comparison, the
threshold and what it means. A threshold may scale another key of the same file (``ref``: the
transparency headline against its bound). ``check`` reads the result files and says, per row, ``met``,
``short`` (the value misses the threshold) or ``missing`` (no file, no key, or no value: not run);
``python -m bench --check`` prints the table and exits 1 when any row is short. Figures the docs table
only reports (baselines, physics bounds, "report") have no row here.
"""

from __future__ import annotations

import json
import math
import operator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

_OPS = {">=": operator.ge, "<=": operator.le, ">": operator.gt, "<": operator.lt, "==": operator.eq}


@dataclass(frozen=True)
class Target:
    """``<file>.json[key] <op> threshold`` (times ``<file>.json[ref]`` when ``ref`` is set).

    ``op`` is one of >=, <=, >, <, == or ``between`` (``threshold`` is then ``(low, high)``, both kept).
    """

    file: str
    key: str
    op: str
    threshold: float | tuple[float, float]
    meaning: str
    ref: str | None = None

    def __post_init__(self) -> None:
        if self.op not in _OPS and self.op != "between":
            raise ValueError(
                f"target {self.file}.{self.key}: comparison {self.op!r} is not one of "
                f"{sorted(_OPS)} or 'between'"
            )

    def text(self) -> str:
        """The target as the table prints it, e.g. ``>= 0.9`` or ``<= 1.25 x bound_headline_error_C``."""
        if self.op == "between":
            lo, hi = self.threshold  # type: ignore[misc]
            return f"{lo:g} .. {hi:g}"
        return f"{self.op} {self.threshold:g}" + (f" x {self.ref}" if self.ref else "")

    def verdict(self, data: dict[str, Any] | None) -> tuple[str, Any]:
        """(``met`` | ``short`` | ``missing``, the value found) for one result document (None: no file)."""
        value = None if data is None else data.get(self.key)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return "missing", value
        if isinstance(value, float) and not math.isfinite(value):
            return "short", value
        if self.op == "between":
            lo, hi = self.threshold  # type: ignore[misc]
            return ("met" if lo <= value <= hi else "short"), value
        limit = float(self.threshold)  # type: ignore[arg-type]
        if self.ref is not None:
            scale = data.get(self.ref) if data is not None else None
            if not isinstance(scale, (int, float)):
                return "missing", value
            limit *= scale
        return ("met" if _OPS[self.op](value, limit) else "short"), value


T = Target
TARGETS: list[Target] = [
    T("sim", "realtime_factor", ">=", 200, "simulated s per wall s, two-rig 10 s scene"),
    T("sim", "max_error_C", "<=", 0.05, "max error vs refined reference, °C"),
    T("sim", "speedup_vs_solve_ivp", ">=", 10, "speed-up vs scipy solve_ivp (BDF) at equal error"),
    T("sim", "pruning_speedup", ">", 1, "speed-up from scene pruning"),
    T("identify", "worst_free_run_error_C", "<=", 0.3, "worst free-run error, order 3, held-out PRBS, °C"),
    T("identify", "fit_ms_order3_10k", "<=", 50, "batch fit, order 3, 10,000 samples, ms"),
    T("identify", "rls_us_per_update", "<=", 30, "RLS update, µs"),
    T(
        "transparency",
        "headline_error_C",
        "<=",
        1.25,
        "skin vs direct touch around each touch, °C, against the optimal currents' bound",
        ref="bound_headline_error_C",
    ),
    T(
        "transparency",
        "pre_contact_mean_error_C",
        "<=",
        0.3,
        "skin vs direct touch 0.5 s before each touch, °C",
    ),
    T("transparency", "null_display_min_ratio_to_project", ">=", 3, "best null display's headline / ours"),
    T("transparency", "drift_10min_C", "<=", 1, "pads in air 10 min after a scene, largest drift, °C"),
    T("nodes", "lockstep_cycles_per_s_virtual", ">=", 2000, "two-node lockstep, in-process virtual bus"),
    T("nodes", "lockstep_cycles_per_s_hub", ">=", 1000, "two processes over the socketcand hub, cycles/s"),
    T("nodes", "late_cycles_100hz_60s", "==", 0, "late cycles, real time 100 Hz, 60 s"),
    T("nodes_lockstep", "lockstep_ratio_vs_raw_virtual", ">=", 0.75, "lockstep / raw ping-pong, virtual bus"),
    T("nodes_lockstep", "lockstep_ratio_vs_raw_hub", ">=", 0.75, "lockstep / raw ping-pong, over the hub"),
    T("nodes_lockstep", "lockstep_cpu_ratio_vs_raw_virtual", ">=", 0.75, "the virtual ratio in CPU time"),
    T("cli", "help_ratio_vs_can_viewer", "<=", 1.5, "`telethermo --help` / `python -m can.viewer --help`"),
    T("cli", "get_ratio_vs_raw_canopen", "<=", 1.5, "`telethermo get` / a minimal canopen SDO read"),
    T("rendering", "material_id_accuracy", ">=", 0.95, "material id, 600 touches in the calibration box"),
    T("monitor", "decode_frames_per_s", ">=", 8000, "`Monitor.feed`, EDS-decoded frames/s"),
    T("monitor", "live_frames_per_s", ">=", 8000, "`recv()` + `feed()`, virtual bus, frames/s"),
    T("monitor", "hub_live_frames_per_s", ">=", 8000, "the same live over a hub process, frames/s"),
    T("realtime", "peer_lost_trips_10min_loaded", "==", 0, "peer-lost trips, 10 min at 100 Hz, loaded"),
    T("conformance", "n_fail", "==", 0, "CiA 301 checks failed through an independent client"),
    T("stress", "n_failed", "==", 0, "stress cases failed"),
    T("stress", "surface_rate_max_C_per_s", "<=", 6, "master pad surface rate, peer trip to +5 s, °C/s"),
    # issue 22: the operating envelope (bench/envelope_bench.py)
    T("envelope", "envelope_n_conditions", ">=", 200, "conditions of the envelope run"),
    T("envelope", "envelope_oscillating_conditions", "==", 0, "conditions whose loop oscillates"),
    T("envelope", "envelope_session_long_cuts", "==", 0, "sessions with a long cut"),
    T("envelope", "envelope_unexpected_trips", "==", 0, "conditions with an unexpected trip"),
    T("envelope", "envelope_beats_best_pad_fraction", ">=", 0.9, "conditions beating the best plain pad"),
    T("envelope", "envelope_median_ratio_to_bound", "<=", 1.25, "median headline error / the bound's"),
    T("envelope", "envelope_captured_fraction_median", ">=", 0.7, "median fraction of the cue captured"),
    T("envelope", "envelope_cue_order_kept_fraction", ">=", 0.95, "fair conditions keeping the cues' order"),
    T("envelope", "render_early_rms_worst_C", "<=", 0.5, "render mode, early RMS error, worst object, °C"),
    T("envelope", "workers_2_speedup", ">=", 1.7, "the matrix on two workers / on one"),
    T("envelope", "envelope_skin_past_clamp_worst_C", "<=", 0.0, "the skin past its clamps, worst, °C"),
    T(
        "envelope",
        "envelope_clamp_reached_fraction",
        ">=",
        1.0,
        "skin within 0.5 °C of a clamp the direct touch passes",
    ),
    T("envelope_heldout", "envelope_session_long_cuts", "==", 0, "held-out draw: sessions with a long cut"),
    T("envelope_heldout", "envelope_unexpected_trips", "==", 0, "held-out draw: an unexpected trip"),
    T("envelope_heldout", "envelope_skin_past_clamp_worst_C", "<=", 0.0, "held-out: skin past clamps, °C"),
    T(
        "envelope_heldout",
        "envelope_clamp_reached_fraction",
        ">=",
        1.0,
        "held-out: skin within 0.5 °C of a passed clamp",
    ),
    # issue 23: material identification across the envelope (bench/material_id_bench.py --envelope)
    T("material_id", "material_id_envelope_n_touches", ">=", 1000, "touches drawn across the envelope"),
    T(
        "material_id",
        "material_id_envelope_accuracy_early",
        ">=",
        0.90,
        "accuracy at <= 0.5 s (abstain = wrong)",
    ),
    T(
        "material_id",
        "material_id_envelope_accuracy_late",
        ">=",
        0.98,
        "accuracy at <= 1.5 s (abstain = wrong)",
    ),
    T("material_id", "material_id_worst_stratum_accuracy_late", ">=", 0.95, "late accuracy, worst stratum"),
    T(
        "material_id",
        "material_id_ece_worst_stratum",
        "<=",
        0.05,
        "expected calibration error, worst stratum",
    ),
    T(
        "material_id",
        "material_id_confident_precision_worst_stratum",
        ">=",
        0.95,
        "accuracy of answers at posterior >= 0.9, worst stratum",
    ),
    T(
        "material_id",
        "material_id_ci95_coverage",
        "between",
        (0.90, 0.98),
        "effusivity 95 % interval coverage",
    ),
    T("material_id", "material_id_fit_cycle_worst_ms", "<=", 0.51, "worst fit work in one control cycle, ms"),
    T(
        "material_id",
        "material_id_fit_position_worst_ms",
        "<=",
        0.51,
        "slowest cycle position of the early fit (median over touches), ms",
    ),
    T(
        "material_id",
        "material_id_late_fit_cycle_worst_ms",
        "<=",
        0.51,
        "slowest cycle of the refined answer's fit (median over touches), ms",
    ),
]


def check(results_dir: Path, targets: list[Target] = TARGETS) -> list[tuple[Target, str, Any]]:
    """(target, met | short | missing, value) for every target, from ``results_dir/<file>.json``."""
    docs: dict[str, dict[str, Any] | None] = {}
    out = []
    for t in targets:
        if t.file not in docs:
            f = results_dir / f"{t.file}.json"
            docs[t.file] = json.loads(f.read_text(encoding="utf-8")) if f.exists() else None
        verdict, value = t.verdict(docs[t.file])
        out.append((t, verdict, value))
    return out


def check_table(rows: list[tuple[Target, str, Any]]) -> str:
    """The verdicts as a plain-text table: file, key, value, target, verdict, meaning."""

    def fmt(v: Any) -> str:
        return "—" if v is None else f"{v:.4g}" if isinstance(v, float) else str(v)

    cells = [["file", "key", "value", "target", "verdict", "meaning"]]
    cells += [[t.file, t.key, fmt(v), t.text(), verdict, t.meaning] for t, verdict, v in rows]
    widths = [max(len(r[i]) for r in cells) for i in range(len(cells[0]) - 1)]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths)) + "  " + r[-1] for r in cells]
    lines.insert(1, "  ".join("-" * w for w in widths) + "  " + "-" * len(cells[0][-1]))
    return "\n".join(lines)
