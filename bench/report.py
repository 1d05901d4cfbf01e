"""Generate the benchmark table of docs/benchmarks.md from bench/results/*.json.

The section between the BEGIN/END markers is rewritten; everything else in the file is kept.
"""

from __future__ import annotations

import io
import json
from pathlib import Path

from bench.report_rows import HEADLINE
from telethermo.atomic import write_bytes_atomic, write_text_atomic

DOCS = Path(__file__).resolve().parent.parent / "docs" / "benchmarks.md"
BEGIN, END = "<!-- BEGIN GENERATED TABLE -->", "<!-- END GENERATED TABLE -->"


def _fmt(v) -> str:
    if v is None:
        return "n/a"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def _provenance_of(data: dict, key: str) -> dict:
    """The provenance of ``key``'s figure in a results file. The envelope's parts can be measured on
    different commits: ``--render-only`` keeps the matrix's (``matrix_provenance``); bench.envelope_controller
    keeps the render sweep's and worker timing's (``render_provenance``, ``timing_provenance``);
    bench.envelope_pads keeps the sessions' (``controller_provenance``; figures against a pad: its own)."""
    prov = data.get("provenance", {})
    if key.startswith("render_"):
        return data.get("render_provenance") or prov
    if key.startswith("workers_"):
        return data.get("timing_provenance") or data.get("matrix_provenance") or prov
    if "pad" in key or "captured" in key:
        return data.get("pads_provenance") or data.get("matrix_provenance") or prov
    return data.get("matrix_provenance") or data.get("controller_provenance") or prov


def table(results_dir: Path) -> str:
    rows = ["| benchmark | figure | value | target | commit | date |", "|---|---|---|---|---|---|"]
    for name, key, what, target in HEADLINE:
        f = results_dir / f"{name}.json"
        if not f.exists():
            rows.append(f"| {name} | {what} (`{key}`) | not run | {target} | | |")
            continue
        data = json.loads(f.read_text())
        prov = _provenance_of(data, key)
        rows.append(
            f"| {name} | {what} (`{key}`) | {_fmt(data.get(key))} | {target} | "
            f"{str(prov.get('commit', ''))[:8]} | {str(prov.get('date', ''))[:10]} |"
        )
    return "\n".join(rows)


def refresh_docs(results_dir: Path, docs: Path = DOCS) -> Path:
    text = docs.read_text() if docs.exists() else f"# Benchmarks\n\n{BEGIN}\n{END}\n"
    if BEGIN not in text or END not in text:
        text += f"\n{BEGIN}\n{END}\n"
    head, rest = text.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    write_text_atomic(docs, f"{head}{BEGIN}\n{table(results_dir)}\n{END}{tail}")
    return docs


# ------------------------------------------------------------------------------------------ plots
def _points(name: str, data: dict) -> tuple[str, str, list[tuple[str, float, float]]]:
    """(x label, y label, [(label, run time s, error)]) of one result file; empty when it has none."""
    pts: list[tuple[str, float, float]] = []
    if name == "sim":
        for label, row in (data.get("settings") or {}).items():
            pts.append((f"sim {label}", row.get("wall_s"), row.get("max_error_C")))
        for row in data.get("solve_ivp") or []:
            pts.append((f"solve_ivp rtol {row.get('rtol')}", row.get("wall_s"), row.get("max_error_C")))
        return "wall time of the two-rig 10 s scene, s", "max error vs refined reference, °C", pts
    if name == "identify":
        for row in data.get("order_table") or []:
            o = ",".join(str(v) for v in row.get("orders", []))
            pts.append((f"{o} {row.get('method')}", row.get("fit_s"), row.get("heldout_max_C")))
        return "fit time, s", "held-out worst free-run error, °C", pts
    if name == "control":
        for row in data.get("rows") or []:
            pts.append((row.get("name", "?"), row.get("run_s"), row.get("early_C")))
        return "run time of the 30 s scene, s", "transparency early mean error, °C", pts
    return "", "", pts


def pareto_front(points: list[tuple[str, float, float]]) -> list[tuple[str, float, float]]:
    """The points no other point beats in both run time and error (lower is better in both)."""
    front, best = [], float("inf")
    for p in sorted(points, key=lambda p: (p[1], p[2])):
        if p[2] < best:
            front.append(p)
            best = p[2]
    return front


def write_plots(results_dir: Path) -> list[Path]:
    """One PNG per benchmark that trades run time against error: log axes, Pareto front marked.
    Needs matplotlib (the `plot` extra); without it, returns [] and says so."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("bench: matplotlib not installed (pip install '.[plot]'): no plots")
        return []

    out = []
    for name in ("sim", "identify", "control"):
        f = results_dir / f"{name}.json"
        if not f.exists():
            continue
        xl, yl, pts = _points(name, json.loads(f.read_text()))
        pts = [
            p
            for p in pts
            if isinstance(p[1], (int, float)) and isinstance(p[2], (int, float)) and p[1] > 0 and p[2] > 0
        ]
        if not pts:
            continue
        front = pareto_front(pts)
        fig, ax = plt.subplots(figsize=(7, 5))
        ax.scatter([p[1] for p in pts], [p[2] for p in pts], s=18, color="0.6", label="configurations")
        ax.plot([p[1] for p in front], [p[2] for p in front], "o-", color="C3", label="Pareto front")
        for p in front:
            ax.annotate(p[0], (p[1], p[2]), fontsize=7, xytext=(4, 4), textcoords="offset points")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(xl)
        ax.set_ylabel(yl)
        ax.set_title(f"bench {name}: run time against error")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
        plt.close(fig)
        out.append(write_bytes_atomic(results_dir / f"{name}.png", buf.getvalue()))
    return out
