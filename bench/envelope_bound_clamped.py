"""Can a display that keeps the skin clamps beat the pad? The clamped optimal-current bound:
``python -m bench.envelope_bound_clamped [--workers N]`` writes ``bench/results/envelope_bound_clamped.json``.

bench.envelope_bound_all's *safe* bound is max(the optimal-current bound, the clamped ideal display): two
lower bounds, each blind to what the other forbids. The bound lets the skin past 43 °C; the ideal display
puts the skin at the clamp the instant the direct touch crosses it, whatever the current limit allows. On a
hot object the display starts each touch at the natural skin temperature, its current limit heats the skin
at a finite rate, and a pad held at 43 °C is already there. This runs the bound once more with the skin kept
inside the clamps at every sample (telethermo.offline.bound, ``clamp_C``; the clamps widened by
bench.envelope_clamp_bound's 0.5 °C, as the ideal display's are, so it stays a lower bound on a display that
reaches "within 0.5 °C" of a clamp): the exact master plant, |I| ≤ 0.8·I_max, the finger matched at each
window's start, no foreknowledge of the touch.

The finger's matched start is clipped to the clamps cell by cell: after a hot touch the direct-touch finger
can start the next window past 43.5 °C, where no display that kept the clamps could have left it (a finger
held inside the clamps, its core at 37 °C, has every cell inside them).

It runs on the conditions whose direct touch takes the skin within :data:`NEAR_C` of a clamp (or past it);
elsewhere the clamped bound is taken to be the bound of envelope_bound_all.json (the optimum tracks a direct
touch that stays that far inside; stated, not measured). Keys: ``clamped_bound_beats_best_pad_fraction``
(over the whole matrix, beside the safe bound's and the controller's), ``lost_to_the_clamp`` (conditions the
safe bound wins and the clamped bound loses, with their parameters), ``reachable_not_won_clamped``, the
median ratio to the clamped bound and the captured share, ``clamp_excess_worst_C``, and two checks:
``clamped_below_clamp_ideal`` (conditions where it ended below the clamped ideal display, which no skin inside
the clamps can beat: empty unless the penalty let the skin out) and ``clamped_below_bound`` (below the free
bound: the optimiser did not converge, or the clipped start helped). The clamps are widened by 0.5 °C so that
the figure stays a lower bound; where the clamped bound wins by less than :data:`NOMINAL_MARGIN_C` it runs
once more with the nominal clamps, [15, 43] °C (``nominal_bound_beats_best_pad_fraction``, ``nominal_lost``).
``--reuse`` takes the clamped bounds of an earlier envelope_bound_clamped.json instead of computing them.
A journal (``envelope_bound_clamped.partial.jsonl``) keeps each finished bound, so a crash loses at most one
per worker; it is removed when the JSON is written.
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
from bench.envelope_bound_all import LISTED, read_journal
from bench.envelope_clamp_bound import SKIN_MARGIN_C
from telethermo.offline.envelope import SKIN_CLAMP_C, Condition

PARTIAL = "envelope_bound_clamped.partial.jsonl"
#: the skin's clamps the bound keeps, °C: the nominal ones widened by the ideal display's margin
CLAMP_C = (SKIN_CLAMP_C[0] - SKIN_MARGIN_C, SKIN_CLAMP_C[1] + SKIN_MARGIN_C)
#: the clamped bound runs where the direct touch's skin comes this near a nominal clamp, °C
NEAR_C = 1.0
#: the nominal clamps' check runs where the clamped bound beats the pad by less than this, °C: moving a clamp
#: 0.5 °C inwards cannot cost more than that where the bound sits at it
NOMINAL_MARGIN_C = 0.5
#: object temperature bands of the summary table, °C
BANDS_C = (12.0, 20.0, 28.0, 38.0, 44.0)


def near_clamp(skin_range_C: list[float]) -> bool:
    """The direct touch's skin (its [min, max], °C) comes within NEAR_C of a nominal clamp.

    >>> near_clamp([30.0, 42.5]), near_clamp([16.5, 41.9]), near_clamp([15.9, 33.0])
    (True, False, True)
    """
    return skin_range_C[0] < SKIN_CLAMP_C[0] + NEAR_C or skin_range_C[1] > SKIN_CLAMP_C[1] - NEAR_C


def _clamped(cond: dict[str, Any]) -> dict[str, Any]:
    return bound_of(Condition.from_json(cond), clamp_C=CLAMP_C)


def clamped_bounds(conds: list[dict[str, Any]], workers: int, folder: Path) -> dict[int, dict[str, Any]]:
    """index -> clamped bound of each of ``conds`` (a crashed run's journal read back, the rest computed)."""
    have = read_journal(folder, PARTIAL)
    todo = [c for c in conds if c["index"] not in have]
    with (
        ProcessPoolExecutor(max_workers=workers) as ex,
        (folder / PARTIAL).open("a", encoding="utf-8") as log,
    ):
        futs = {ex.submit(_clamped, c): c["index"] for c in todo}
        for n, f in enumerate(as_completed(futs), 1):
            b = f.result()
            have[b["index"]] = b
            log.write(json.dumps(b) + "\n")
            log.flush()
            print(
                f"{n}/{len(todo)} condition {b['index']}: clamped bound {b['bound_headline_C']:.3f} °C",
                flush=True,
            )
    return have


def _stored(r: dict[str, Any]) -> dict[str, Any]:
    """A row of an earlier results file as the clamped bound it holds."""
    return {
        "index": r["index"],
        "bound_headline_C": r["clamped_bound_headline_C"],
        "clamp_excess_max_C": r["clamp_excess_max_C"],
    }


def _nominal(cond: dict[str, Any]) -> dict[str, Any]:
    return bound_of(Condition.from_json(cond), clamp_C=SKIN_CLAMP_C)


def nominal_check(rows: list[dict[str, Any]], env: dict[str, Any], workers: int) -> dict[str, Any]:
    """The bound with the nominal clamps (the skin inside [15, 43] °C, no margin) where the clamped bound wins
    by less than NOMINAL_MARGIN_C: which of those it still wins, and the matrix's share with them."""
    conds = {r["condition"]["index"]: r["condition"] for r in env["conditions"]}
    close = [
        r
        for r in rows
        if r["clamped_bound_run"]
        and 0.0 < r["best_pad_headline_C"] - r["clamped_bound_headline_C"] < NOMINAL_MARGIN_C
    ]
    with ProcessPoolExecutor(max_workers=workers) as ex:
        got = list(ex.map(_nominal, [conds[r["index"]] for r in close]))
    per = [
        {
            "index": r["index"],
            "best_pad_headline_C": r["best_pad_headline_C"],
            "clamped_bound_headline_C": r["clamped_bound_headline_C"],
            "nominal_bound_headline_C": g["bound_headline_C"],
            "clamp_excess_max_C": g["clamp_excess_max_C"],
            "nominal_beats_best_pad": bool(g["bound_headline_C"] < r["best_pad_headline_C"]),
        }
        for r, g in zip(close, got)
    ]
    lost = sum(not p["nominal_beats_best_pad"] for p in per)
    wins = sum(bool(r["clamped_bound_beats_best_pad"]) for r in rows)
    return {
        "nominal_clamps_C": list(SKIN_CLAMP_C),
        "nominal_bound_beats_best_pad_fraction": (wins - lost) / len(rows),
        "nominal_lost": [p["index"] for p in per if not p["nominal_beats_best_pad"]],
        "nominal_checked": per,
    }


def row(a: dict[str, Any], cb: dict[str, Any] | None) -> dict[str, Any]:
    """One condition of envelope_bound_all.json with its clamped bound (``cb``; None: not near a clamp, the
    bound stands in)."""
    clamped = a["bound_headline_C"] if cb is None else max(cb["bound_headline_C"], 0.0)
    pad, ours = a["best_pad_headline_C"], a["headline_C"]
    return {
        **{k: a[k] for k in ("index", "headline_C", "best_pad_headline_C", "best_pad", "bound_headline_C")},
        **{k: a[k] for k in ("clamp_bound_headline_C", "safe_bound_headline_C", "beats_best_pad")},
        "safe_bound_beats_best_pad": a["safe_bound_beats_best_pad"],
        "clamped_bound_headline_C": clamped,
        "clamped_bound_run": cb is not None,
        "clamp_excess_max_C": None if cb is None else cb["clamp_excess_max_C"],
        "clamped_bound_beats_best_pad": bool(clamped < pad),
        "ratio_to_clamped_bound": ours / clamped,
        "captured_fraction_clamped": (pad - ours) / (pad - clamped) if pad > clamped else None,
        "master_max_cooling_A": a["master_max_cooling_A"],
        **{k: a[k] for k in LISTED},
    }


def by_band(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per object-temperature band: conditions, and how many the controller, the safe bound and the
    clamped bound win against the best pad."""
    edges = (-np.inf, *BANDS_C, np.inf)
    out = []
    for lo, hi in zip(edges, edges[1:]):
        rs = [r for r in rows if lo <= r["object_T_C"] < hi]
        out.append(
            {
                "object_T_C": [None if not np.isfinite(lo) else lo, None if not np.isfinite(hi) else hi],
                "n": len(rs),
                **{
                    k: sum(bool(r[k]) for r in rs)
                    for k in ("beats_best_pad", "safe_bound_beats_best_pad", "clamped_bound_beats_best_pad")
                },
            }
        )
    return out


def summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The matrix against the clamped bound."""
    frac = lambda k: float(np.mean([r[k] for r in rows]))  # noqa: E731
    run = [r for r in rows if r["clamped_bound_run"]]
    cap = [r["captured_fraction_clamped"] for r in rows if r["captured_fraction_clamped"] is not None]
    keep = ("index", "clamped_bound_headline_C", "safe_bound_headline_C", "best_pad_headline_C", "best_pad")
    return {
        "clamped_n_conditions": len(rows),
        "clamped_n_run": len(run),
        "clamped_bound_beats_best_pad_fraction": frac("clamped_bound_beats_best_pad"),
        "safe_bound_beats_best_pad_fraction": frac("safe_bound_beats_best_pad"),
        "controller_beats_best_pad_fraction": frac("beats_best_pad"),
        "median_ratio_to_clamped_bound": float(np.median([r["ratio_to_clamped_bound"] for r in rows])),
        "captured_fraction_median_clamped": float(np.median(cap)) if cap else None,
        "clamped_below_clamp_ideal": [
            r["index"] for r in run if r["clamped_bound_headline_C"] < r["clamp_bound_headline_C"] - 0.01
        ],
        "clamped_below_bound": [
            r["index"] for r in run if r["clamped_bound_headline_C"] < r["bound_headline_C"] - 0.01
        ],
        "clamp_excess_worst_C": max((r["clamp_excess_max_C"] for r in run), default=None),
        "by_object_band": by_band(rows),
        "reachable_not_won_clamped": [
            r["index"] for r in rows if r["clamped_bound_beats_best_pad"] and not r["beats_best_pad"]
        ],
        "won_against_the_clamped_bound": [
            r["index"] for r in rows if r["beats_best_pad"] and not r["clamped_bound_beats_best_pad"]
        ],
        "lost_to_the_clamp": [
            {**{k: r[k] for k in keep}, **{k: r[k] for k in LISTED}}
            for r in rows
            if r["safe_bound_beats_best_pad"] and not r["clamped_bound_beats_best_pad"]
        ],
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m bench.envelope_bound_clamped", description=__doc__.split("\n")[0]
    )
    ap.add_argument("--workers", type=int, default=2, help="processes on this machine (default 2)")
    ap.add_argument("--reuse", action="store_true", help="the clamped bounds of the present results file")
    a = ap.parse_args(argv)
    folder = current_results_dir()
    read = lambda name: json.loads((folder / name).read_text(encoding="utf-8"))  # noqa: E731
    env, ball, clamp = (
        read("envelope.json"),
        read("envelope_bound_all.json"),
        read("envelope_clamp_bound.json"),
    )
    near = {c["index"] for c in clamp["conditions"] if near_clamp(c["direct_skin_range_C"])}
    conds = [
        r["condition"] for r in env["conditions"] if r["condition"]["index"] in near and "headline_C" in r
    ]
    t0 = time.perf_counter()
    if a.reuse:  # the clamped bounds (and the time they took) of an earlier run
        old = read("envelope_bound_clamped.json")
        have = {r["index"]: _stored(r) for r in old["conditions"] if r["clamped_bound_run"]}
        bounds_s = old["clamped_bounds_wall_s"] if "clamped_bounds_wall_s" in old else old["wall_s"]
    else:
        have = clamped_bounds(conds, a.workers, folder)
        bounds_s = time.perf_counter() - t0
    rows = [row(b, have.get(b["index"])) for b in ball["conditions"]]
    data = {
        **summary(rows),
        **nominal_check(rows, env, a.workers),
        "clamp_C": list(CLAMP_C),
        "near_C": NEAR_C,
        "clamped_bounds_wall_s": bounds_s,
        "wall_s": time.perf_counter() - t0,
        "workers": a.workers,
        "inputs_provenance": {"bound_all": ball.get("provenance"), **ball.get("inputs_provenance", {})},
        "conditions": rows,
    }
    write_results("envelope_bound_clamped", data)
    (folder / PARTIAL).unlink(missing_ok=True)
    print(
        json.dumps({k: v for k, v in data.items() if k not in ("conditions", "lost_to_the_clamp")}, indent=1)
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
