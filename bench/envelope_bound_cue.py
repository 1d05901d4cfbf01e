"""Does the physics allow issue 22's cue-order target? ``python -m bench.envelope_bound_cue [--workers N]``
writes ``bench/results/envelope_bound_cue.json``; ``--lost`` runs every fair condition whose order the
shipped controller lost instead (``envelope_bound_cue_lost.json``).

``envelope_cue_order_kept_fraction`` (target ≥ 0.95) counts the conditions whose display keeps the direct
touch's order of the material cue (heat drawn out of the finger in the first second of each touch) on every
pair, over the conditions where the direct cues differ by ≥ 20 %. This runs the optimal-current bound of
the envelope's bound subset (the same conditions as ``bound_conditions`` in bench/results/envelope.json:
every 10th Latin-hypercube draw and the base scene; ``bench.bound_run.run_bound``: the exact master
plant, the finger matched before each touch, no foreknowledge) and scores the *bound's* cues the same way:
if the current that tracks the direct touch's skin best cannot keep the order, no controller can, and the
target is out of reach there. The bound minimises the skin's error, not the cue's, so it is a bound on the
temperature and only a reference for the heat.

Both figures on the same conditions: ``bound_cue_order_kept_fraction`` and
``controller_cue_order_kept_fraction`` (the shipped controller's from envelope.json), over ``n_fair`` fair
conditions. The trivial baseline, a pad held at a constant temperature, draws the same heat whatever the
material and keeps no order (0 by construction; not run).
"""

from __future__ import annotations

import argparse
import json
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from bench.common import RESULTS_DIR, write_results
from bench.bound_run import run_bound
from bench.transparency_bench import reference_track
from telethermo.offline.envelope import Condition, condition_scene
from telethermo.offline.transparency import cue_discrimination


def bound_cues(cond: dict[str, Any]) -> dict[str, Any]:
    """The bound's and the direct touch's cue per touch of one condition, and whether the order is kept."""
    c = Condition.from_json(cond)
    sc, _ = condition_scene(c)
    t_ref, skin_ref, q_ref, cells = reference_track(sc)
    b = run_bound(sc, t_ref, skin_ref, cells, maxiter=150, front_weights=(), front_touches=0, q_ref=q_ref)
    per = [{k: p[k] for k in ("object", "cue_J", "direct_cue_J")} for p in b["per_touch"]]
    cue = cue_discrimination(per)
    return {"index": c.index, "bound_order_kept": bool(cue["order_kept"]), "per_touch": per}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m bench.envelope_bound_cue", description=__doc__.split("\n\n")[0]
    )
    ap.add_argument("--workers", type=int, default=2, help="processes (default 2)")
    ap.add_argument("--shipped", default=str(RESULTS_DIR / "envelope.json"), help="the matrix's results")
    ap.add_argument(
        "--lost",
        action="store_true",
        help="instead of the bound subset, every fair condition whose order the controller lost "
        "(writes envelope_bound_cue_lost.json)",
    )
    a = ap.parse_args(argv)
    with open(a.shipped, encoding="utf-8") as f:
        env = json.load(f)
    rows = {r["condition"]["index"]: r for r in env["conditions"] if "headline_C" in r}
    rows[-1] = env["base"]
    if a.lost:
        subset = [
            {"index": i, "condition": r["condition"]}
            for i, r in sorted(rows.items())
            if i >= 0 and r.get("cue_fair") and not r.get("cue_order_kept")
        ]
    else:
        subset = env["bound_conditions"]
    with ProcessPoolExecutor(max_workers=a.workers) as ex:
        out = list(ex.map(bound_cues, [b["condition"] for b in subset]))
    per = []
    for b, o in zip(subset, out):
        r = rows.get(b["index"]) or {}
        per.append(
            {
                "index": b["index"],
                "cue_fair": r.get("cue_fair"),
                "controller_order_kept": r.get("cue_order_kept"),
                "bound_order_kept": o["bound_order_kept"],
                "per_touch": o["per_touch"],
            }
        )
    fair = [p for p in per if p["cue_fair"]]
    n = max(len(fair), 1)
    data = {
        "n_conditions": len(per),
        "n_fair": len(fair),
        "bound_cue_order_kept_fraction": sum(p["bound_order_kept"] for p in fair) / n,
        "controller_cue_order_kept_fraction": sum(bool(p["controller_order_kept"]) for p in fair) / n,
        "bound_cue_order_kept_fraction_all": sum(p["bound_order_kept"] for p in per) / max(len(per), 1),
        "fair_lost_by_bound": [p["index"] for p in fair if not p["bound_order_kept"]],
        "fair_lost_by_controller_only": [
            p["index"] for p in fair if p["bound_order_kept"] and not p["controller_order_kept"]
        ],
        "conditions": per,
    }
    path = write_results("envelope_bound_cue" + ("_lost" if a.lost else ""), data)
    print(json.dumps({k: v for k, v in data.items() if k != "conditions"}, indent=1))
    print(f"written {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
