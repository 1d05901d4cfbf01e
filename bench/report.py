"""Generate the benchmark table of docs/benchmarks.md from bench/results/*.json.

The section between the BEGIN/END markers is rewritten; everything else in the file is kept.
"""
from __future__ import annotations

import json
from pathlib import Path

from telethermo.atomic import write_text_atomic

DOCS = Path(__file__).resolve().parent.parent / "docs" / "benchmarks.md"
BEGIN, END = "<!-- BEGIN GENERATED TABLE -->", "<!-- END GENERATED TABLE -->"

# (results file, key, what it means, target)
HEADLINE = [
    ("sim", "realtime_factor", "simulated s per wall s, two-rig 10 s scene, default settings", "≥ 200"),
    ("sim", "max_error_C", "max error vs refined reference, °C", "≤ 0.05"),
    ("sim", "speedup_vs_solve_ivp", "speed-up vs scipy solve_ivp (BDF) at equal error", "≥ 10"),
    ("sim", "pruning_speedup", "speed-up from scene pruning", "> 1"),
    ("identify", "worst_free_run_error_C", "worst free-run error, order 3, held-out PRBS, °C", "≤ 0.3 (aim 0.1)"),
    ("identify", "flux_error_W", "heat-flux model error, W", "~0.0025"),
    ("identify", "fit_ms_order3_10k", "batch fit, order 3, 10,000 samples, ms", "≤ 50"),
    ("identify", "rls_us_per_update", "RLS update, µs", "≤ 30"),
    ("control", "transparency_early_mean_error_C", "master contact T vs direct touch, 0.1–1 s, mean, °C", "≤ 0.5"),
    ("control", "transparency_late_mean_error_C", "same, 1–3 s, °C", "—"),
    ("control", "tracking_rms_C", "tracking RMS in steady contact, °C", "≤ 0.1"),
    ("nodes", "lockstep_cycles_per_s_virtual", "two-node lockstep, in-process virtual bus, cycles/s", "≥ 2000"),
    ("nodes", "lockstep_cycles_per_s_hub", "two processes over the socketcand hub, cycles/s", "≥ 1000"),
    ("nodes", "lockstep_cycles_per_s_vcan", "two processes over vcan0 (in the VM), cycles/s", "≥ 1000 natively"),
    ("nodes", "late_cycles_100hz_60s", "late cycles, real time 100 Hz, 60 s", "0"),
    ("nodes", "late_fraction_1khz", "late fraction, real time 1 kHz", "report"),
    ("stress", "n_failed", "stress cases failed (of n_cases)", "0"),
]


def _fmt(v) -> str:
    if v is None:
        return "n/a"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def table(results_dir: Path) -> str:
    rows = ["| benchmark | figure | value | target | commit | date |", "|---|---|---|---|---|---|"]
    for name, key, what, target in HEADLINE:
        f = results_dir / f"{name}.json"
        if not f.exists():
            rows.append(f"| {name} | {what} (`{key}`) | not run | {target} | | |")
            continue
        data = json.loads(f.read_text())
        prov = data.get("provenance", {})
        rows.append(f"| {name} | {what} (`{key}`) | {_fmt(data.get(key))} | {target} | "
                    f"{str(prov.get('commit', ''))[:8]} | {str(prov.get('date', ''))[:10]} |")
    return "\n".join(rows)


def refresh_docs(results_dir: Path, docs: Path = DOCS) -> Path:
    text = docs.read_text() if docs.exists() else f"# Benchmarks\n\n{BEGIN}\n{END}\n"
    if BEGIN not in text or END not in text:
        text += f"\n{BEGIN}\n{END}\n"
    head, rest = text.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    write_text_atomic(docs, f"{head}{BEGIN}\n{table(results_dir)}\n{END}{tail}")
    return docs
