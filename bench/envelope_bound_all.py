"""Can any display beat the constant pad? The optimal-current bound on every condition of the matrix:
``python -m bench.envelope_bound_all [--workers N]`` writes ``bench/results/envelope_bound_all.json``.

Issue 22 asks the controller to beat the best constant pad in 90 % of the envelope
(``envelope_beats_best_pad_fraction``) and measures its distance to the physics on a subset of 21 conditions
(``envelope_median_ratio_to_bound``). This runs the same bound (bench.envelope_bench.bound_of:
telethermo/offline/bound.py, the exact master plant, currents limited to 0.8·I_max, the finger matched to the
direct touch's at each window's start, no foreknowledge of the touch) on all of them, so the share of the
matrix in which *any* display of that module could beat the pad is a measured figure, not a hope:

- ``bound_beats_best_pad_fraction``: the optimal-current bound against the best pad of the same condition
  (envelope.json's pads: the same direct touch);
- ``safe_bound_beats_best_pad_fraction``: the same with max(bound, the clamped ideal display of
  bench/results/envelope_clamp_bound.json): the bound lets the skin past the clamps, which no conforming
  display may do; the larger of two lower bounds on a display's error is one too. This is the ceiling of
  ``envelope_beats_best_pad_fraction`` for displays that start each touch as well as the bound does;
- ``reachable_not_won``: conditions the safe bound wins and the controller loses (what a better controller
  could still take), and ``bound_loses``: conditions no display of that module wins, with their parameters;
- the ratio to the bound and the captured share over the whole matrix, beside the subset's, so the subset's
  figures can be checked for being representative.

The subset's bounds in envelope.json are reused (same code; their commit under ``inputs_provenance``); the
rest are computed.
Each finished bound is appended to ``envelope_bound_all.partial.jsonl`` beside the results and a re-run skips
what it holds, so a crash loses at most one bound per worker; the file is removed when the JSON is written.
"""

from __future__ import annotations

import argparse
import json
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

import numpy as np

from bench.common import current_results_dir, write_results
from bench.envelope_bench import bound_of
from bench.envelope_clamp_bound import against_bounds
from telethermo.offline.envelope import Condition

PARTIAL = "envelope_bound_all.partial.jsonl"
#: the parameters listed beside a condition no display wins
LISTED = ("object_T_C", "ambient_C", "m_seebeck_x", "m_R_x", "m_I_max_A", "probe_force_N", "delay_ms")


def _bound(cond: dict[str, Any]) -> dict[str, Any]:
    return bound_of(Condition.from_json(cond))


def read_journal(folder: Path, name: str = PARTIAL) -> dict[int, dict[str, Any]]:
    """index -> bound of the journal ``name`` in ``folder`` (a line cut by a crash is skipped)."""
    path = folder / name
    if not path.exists():
        return {}
    out = {}
    for line in path.read_text(encoding="utf-8").splitlines():
        try:
            b = json.loads(line)
        except json.JSONDecodeError:  # a line cut by a crash: that bound runs again
            continue
        out[int(b["index"])] = b
    return out


def bounds(env: dict[str, Any], workers: int, folder: Path) -> dict[int, dict[str, Any]]:
    """index -> bound of every scored condition (the subset's reused, the finished ones of a crashed run
    read back, the rest computed on ``workers`` processes)."""
    have = {b["index"]: {**b, "source": "envelope.json bound subset"} for b in env["bound_conditions"]}
    have.update({i: b for i, b in read_journal(folder).items() if i not in have})
    todo = [
        r["condition"] for r in env["conditions"] if "headline_C" in r and r["condition"]["index"] not in have
    ]
    with (
        ProcessPoolExecutor(max_workers=workers) as ex,
        (folder / PARTIAL).open("a", encoding="utf-8") as log,
    ):
        futs = {ex.submit(_bound, c): c["index"] for c in todo}
        for n, f in enumerate(as_completed(futs), 1):
            b = {**f.result(), "source": "this run"}
            have[b["index"]] = b
            log.write(json.dumps(b) + "\n")
            log.flush()
            print(f"{n}/{len(todo)} condition {b['index']}: bound {b['bound_headline_C']:.3f} °C", flush=True)
    return have


def row(r: dict[str, Any], b: dict[str, Any], clamp: dict[str, Any]) -> dict[str, Any]:
    """One condition: ours, the best pad, the bound, the clamped ideal display and the safe bound, °C."""
    pad, ours = r["best_pad_headline_C"], r["headline_C"]
    c = r["condition"]
    vs = against_bounds(ours, pad, b["bound_headline_C"], clamp["clamp_bound_headline_C"])
    return {
        "index": c["index"],
        "headline_C": ours,
        "best_pad_headline_C": pad,
        "best_pad": r["best_pad"],
        "bound_headline_C": b["bound_headline_C"],
        "clamp_bound_headline_C": clamp["clamp_bound_headline_C"],
        **vs,
        "beats_best_pad": bool(r["beats_best_pad"]),
        "bound_beats_best_pad": bool(b["bound_headline_C"] < pad),
        "safe_bound_beats_best_pad": bool(vs["safe_bound_headline_C"] < pad),
        "master_max_cooling_A": r["gain_fit"]["master"].get("max_cooling_A"),
        **{k: c[k] for k in LISTED},
        "bound_source": b.get("source", ""),
    }


def summary(rows: list[dict[str, Any]], env: dict[str, Any]) -> dict[str, Any]:
    """The matrix's figures against the bound, and the subset's beside them."""
    frac = lambda k: float(np.mean([p[k] for p in rows]))  # noqa: E731
    ratio = np.array([p["ratio_to_bound"] for p in rows])
    cap = [p["captured_fraction_safe"] for p in rows if p["captured_fraction_safe"] is not None]
    return {
        "bound_all_n_conditions": len(rows),
        "controller_beats_best_pad_fraction": frac("beats_best_pad"),
        "bound_beats_best_pad_fraction": frac("bound_beats_best_pad"),
        "safe_bound_beats_best_pad_fraction": frac("safe_bound_beats_best_pad"),
        "median_ratio_to_bound": float(np.median(ratio)),
        "p90_ratio_to_bound": float(np.percentile(ratio, 90)),
        "worst_ratio_to_bound": float(ratio.max()),
        "median_ratio_to_safe_bound": float(np.median([p["ratio_to_safe_bound"] for p in rows])),
        "captured_fraction_median_safe": float(np.median(cap)) if cap else None,
        "subset_median_ratio_to_bound": env.get("envelope_median_ratio_to_bound"),
        "subset_captured_fraction_median": env.get("envelope_captured_fraction_median"),
        "reachable_not_won": [
            p["index"] for p in rows if p["safe_bound_beats_best_pad"] and not p["beats_best_pad"]
        ],
        "won_against_the_bound": [
            p["index"] for p in rows if p["beats_best_pad"] and not p["bound_beats_best_pad"]
        ],
        "bound_loses": [
            {
                k: p[k]
                for k in (
                    "index",
                    "bound_headline_C",
                    "safe_bound_headline_C",
                    "best_pad_headline_C",
                    "best_pad",
                    "master_max_cooling_A",
                    *LISTED,
                )
            }
            for p in rows
            if not p["safe_bound_beats_best_pad"]
        ],
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m bench.envelope_bound_all", description=__doc__.split("\n")[0]
    )
    ap.add_argument("--workers", type=int, default=2, help="processes on this machine (default 2)")
    a = ap.parse_args(argv)
    folder = current_results_dir()
    env = json.loads((folder / "envelope.json").read_text(encoding="utf-8"))
    clamp = json.loads((folder / "envelope_clamp_bound.json").read_text(encoding="utf-8"))
    by_clamp = {c["index"]: c for c in clamp["conditions"]}
    t0 = time.perf_counter()
    have = bounds(env, a.workers, folder)
    scored = [r for r in env["conditions"] if "headline_C" in r]
    rows = [row(r, have[r["condition"]["index"]], by_clamp[r["condition"]["index"]]) for r in scored]
    data = {
        **summary(rows, env),
        "wall_s": time.perf_counter() - t0,
        "workers": a.workers,
        # what the bounds are compared with was measured earlier: the sessions' and the pads' commits (the
        # table names this run's, the bounds')
        "inputs_provenance": {
            "sessions": env.get("controller_provenance") or env.get("provenance"),
            "pads": env.get("pads_provenance"),
            "subset_bounds": env.get("bounds_provenance"),
        },
        "conditions": rows,
    }
    write_results("envelope_bound_all", data)
    (folder / PARTIAL).unlink(missing_ok=True)
    print(json.dumps({k: v for k, v in data.items() if k not in ("conditions", "bound_loses")}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
