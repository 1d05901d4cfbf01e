"""Is the gap in the touch or before it? The clamped bound started from the display's own state:
``python -m bench.envelope_bound_from_display [--workers N]`` writes
``bench/results/envelope_bound_from_display.json``.

The clamped bound (bench.envelope_bound_clamped) starts each window with the direct-touch finger. After a hot
or cold touch that finger is far from where a clamped display left the operator's (condition 207: 44.7 °C
against the display's 41.2 °C half a second before the second touch). So its win over the controller mixes
two things: what the display does during the window, and where the session's history put the finger. This
runs the session as the matrix does, takes the master rig's whole state (finger, pad stack, plates, sink) at
each window's start (t_on − 0.5 s), and runs the same clamped bound (skin inside [14.5, 43.5] °C, |I| ≤
0.8·I_max, no foreknowledge of the touch) from there. The bound knows the direct touch's skin at every sample
as it comes, and the controller does not: it is the best any display could do in the window *from where ours
stood*.

- ``from_display_beats_best_pad``: conditions where that bound still beats the best pad. The controller's
  control during the window could win these without a change to what happens between touches;
- per condition, ours, the bound from our start and the matched-start clamped bound: window, pre-touch (the
  0.5 s before) and early (the first second) errors, first touch and later touches apart. The first touch
  starts where the direct touch does, so the start matters on the later ones only.

It runs on the conditions the clamped bound wins and the controller loses (envelope_bound_clamped.json's
``reachable_not_won_clamped``). Its bounds search from one start (bench.envelope_bound_restart: on a module
whose cooling peak lies inside its limit one start can stop at a local optimum; a restart only lowers a
bound, so the beats-pad share is a floor).
"""

from __future__ import annotations

import argparse
import functools
import json
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np

from bench.bound_run import PRE_N, run_bound
from bench.common import current_results_dir, write_results
from bench.envelope_bound_clamped import CLAMP_C
from bench.transparency_bench import honest, reference_track
from telethermo.offline.envelope import Condition, condition_scene, condition_session

KEYS = ("window_C", "pre_C", "early_C")


class _Snapshots:
    """The master rig, its state kept at the samples ``ks`` (``states``: sample -> the rig's state)."""

    def __init__(self, rig: Any, ks: set[int]) -> None:
        self._rig, self._ks = rig, ks
        self.states: dict[int, np.ndarray] = {}

    def __getattr__(self, name: str) -> Any:
        return getattr(self._rig, name)

    def advance(self, dt_s: float) -> Any:
        out = self._rig.advance(dt_s)
        k = int(round(self._rig.t_s / self._rig.period_s))
        if k in self._ks:
            self.states[k] = self._rig.x.copy()
        return out


def _means(per: list[dict[str, Any]]) -> dict[str, Any]:
    first, later = per[:1], per[1:]
    out: dict[str, float | None] = {k: float(np.mean([p[k] for p in per])) for k in KEYS}
    out["first_window_C"] = float(first[0]["window_C"]) if first else None
    out["later_window_C"] = float(np.mean([p["window_C"] for p in later])) if later else None
    return out


def from_display(cond: dict[str, Any]) -> dict[str, Any]:
    """Ours, the clamped bound from our state and the matched-start clamped bound, per touch and mean, °C."""
    c = Condition.from_json(cond)
    sc0, _ = condition_scene(c)
    ks = {int(round(t.start_s / sc0.period_s)) - PRE_N for t in sc0.slave_contacts}
    box: dict[str, _Snapshots] = {}

    def path(rig: Any, role: str) -> Any:
        if role != "master":
            return rig
        box["m"] = _Snapshots(rig, ks)
        return box["m"]

    sc, res, _fits = condition_session(c, rig_path=path)
    tf = honest(res.recording)
    t_ref, skin_ref, _q, cells = reference_track(sc)
    states = box["m"].states
    starts = [states[int(round(t.start_s / sc.period_s)) - PRE_N] for t in sc.slave_contacts]
    bound = functools.partial(
        run_bound, sc, t_ref, skin_ref, cells, maxiter=150, front_weights=(), front_touches=0, clamp_C=CLAMP_C
    )
    ours_b = bound(starts=starts)
    matched = bound()
    ours = [{k: p[k] for k in KEYS} for p in tf["per_touch"]]
    fb = [{k: p[k] for k in (*KEYS, "clamp_excess_C")} for p in ours_b["per_touch"]]
    mb = [{k: p[k] for k in KEYS} for p in matched["per_touch"]]
    return {
        "index": c.index,
        "ours": _means(ours),
        "from_display": _means(fb),
        "matched": _means(mb),
        "clamp_excess_max_C": float(max(p["clamp_excess_C"] for p in fb)),
        "touches": {"ours": ours, "from_display": fb, "matched": mb},
    }


def summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """How much of the gap to the pad is the window's control and how much the start."""
    med = lambda f: float(np.median([f(r) for r in rows]))  # noqa: E731
    later = [r for r in rows if r["ours"]["later_window_C"] is not None]
    return {
        "from_display_n_conditions": len(rows),
        "from_display_beats_best_pad": [
            r["index"] for r in rows if r["from_display"]["window_C"] < r["best_pad_headline_C"]
        ],
        "from_display_beats_best_pad_fraction": float(
            np.mean([r["from_display"]["window_C"] < r["best_pad_headline_C"] for r in rows])
        ),
        "median_ours_minus_from_display_C": med(
            lambda r: r["ours"]["window_C"] - r["from_display"]["window_C"]
        ),
        "median_from_display_minus_matched_C": med(
            lambda r: r["from_display"]["window_C"] - r["matched"]["window_C"]
        ),
        "median_later_touches_ours_minus_from_display_C": float(
            np.median([r["ours"]["later_window_C"] - r["from_display"]["later_window_C"] for r in later])
        ),
        "median_first_touch_ours_minus_from_display_C": med(
            lambda r: r["ours"]["first_window_C"] - r["from_display"]["first_window_C"]
        ),
        "clamp_excess_worst_C": max(r["clamp_excess_max_C"] for r in rows),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m bench.envelope_bound_from_display", description=__doc__.split("\n")[0]
    )
    ap.add_argument("--workers", type=int, default=2, help="processes on this machine (default 2)")
    ap.add_argument("--only", type=int, nargs="*", help="these condition indices (default: all it runs on)")
    a = ap.parse_args(argv)
    folder = current_results_dir()
    env = json.loads((folder / "envelope.json").read_text(encoding="utf-8"))
    clamped = json.loads((folder / "envelope_bound_clamped.json").read_text(encoding="utf-8"))
    by = {r["index"]: r for r in clamped["conditions"]}
    idx = a.only if a.only else clamped["reachable_not_won_clamped"]
    conds = [r["condition"] for r in env["conditions"] if r["condition"]["index"] in set(idx)]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=a.workers) as ex:
        got = list(ex.map(from_display, conds))
    keep = ("headline_C", "best_pad_headline_C", "clamped_bound_headline_C", "object_T_C", "ambient_C")
    rows = [{**{k: by[g["index"]][k] for k in keep}, **g} for g in got]
    data = {
        **summary(rows),
        "clamp_C": list(CLAMP_C),
        "wall_s": time.perf_counter() - t0,
        "workers": a.workers,
        "conditions": rows,
    }
    write_results("envelope_bound_from_display", data)
    print(json.dumps({k: v for k, v in data.items() if k != "conditions"}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
