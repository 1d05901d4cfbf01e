"""Which touches make a condition "oscillate" (issue 22): the conditions envelope.json flags, re-run, and
their flagged touches counted by round of the §5.3 schedule.

``python -m bench.envelope_oscillation_rounds [--gains identified|shipped] [--workers N] [--shipped PATH]
[--only I,J] [--out NAME]`` writes ``bench/results/NAME.json`` (default ``envelope_oscillation_rounds``).
``--gains shipped`` runs the shipped gains whatever the rig: the control that the count can see a limit
cycle (the shipped gains ring on 88 of the 216 conditions).

The schedule touches each of the condition's three materials twice (round 1: the first three touches, round
2: the next three). A limit cycle is a property of the loop with the rig and the object, so it comes back when
the same material is touched again; an excursion of the pair's common mode from the state the session starts
in (the probe and the objects at their initial temperatures) does not. The figure does not change the
oscillation figure or its target (``envelope_oscillating_conditions`` in envelope.json stays as measured);
it says what the flagged touches are.
"""

from __future__ import annotations

import argparse
import math
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from bench.common import write_results
from bench.envelope_candidate import add_matrix_args, load_shipped, only
from telethermo.offline import envelope
from telethermo.offline.oscillation import OSCILLATION_LIMIT

ROUND_TOUCHES = 3
"""Touches per round of the §5.3 schedule (one per material)."""


def touches_by_round(cond: dict[str, Any], gains: str = "identified") -> dict[str, Any]:
    """Run one condition (its parameters as in envelope.json) with ``gains`` ("identified" or "shipped") and
    return its touches with their round."""
    c = envelope.Condition.from_json(cond)
    r = envelope.run_condition(c, with_pads=False, gains=gains)
    touches = sorted(r["oscillation_touches"], key=lambda t: t["t_on_s"])
    return {
        "index": c.index,
        "oscillating": r["oscillating"],
        "oscillation_ratio": r["oscillation_ratio"],
        "touches": [{**t, "round": 1 + i // ROUND_TOUCHES} for i, t in enumerate(touches)],
    }


def summarise(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Flagged touches per round; the conditions whose flag comes back on the same material in round 2 (or
    appears there first), and, the stricter count, every condition with any flagged touch in round 2."""
    flagged = [t for r in rows for t in r["touches"] if t["oscillating"]]
    again, any2 = [], []
    for r in rows:
        first = {t["object"] for t in r["touches"] if t["oscillating"] and t["round"] == 1}
        second = {t["object"] for t in r["touches"] if t["oscillating"] and t["round"] >= 2}
        if first & second or (second and not first):
            again.append(r["index"])
        if second:
            any2.append(r["index"])
    worst2 = [
        max(
            (t["ratio"] for t in r["touches"] if t["round"] >= 2 and math.isfinite(t["ratio"])),
            default=math.nan,
        )
        for r in rows
    ]
    return {
        "oscillation_rounds_conditions": len(rows),
        "oscillation_rounds_still_flagged": sum(bool(r["oscillating"]) for r in rows),
        "oscillation_rounds_flagged_touches_round_1": sum(t["round"] == 1 for t in flagged),
        "oscillation_rounds_flagged_touches_round_2": sum(t["round"] >= 2 for t in flagged),
        "oscillation_rounds_recurring_conditions": again,
        "oscillation_rounds_round_2_flagged_conditions": any2,
        "oscillation_rounds_round_2_worst_ratio": max((w for w in worst2 if math.isfinite(w)), default=None),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.envelope_oscillation_rounds", description=__doc__)
    add_matrix_args(ap, "comma-separated condition indices (default: those envelope.json flags)")
    ap.add_argument("--gains", choices=("identified", "shipped"), default="identified")
    ap.add_argument("--out", default="envelope_oscillation_rounds", help="result name")
    a = ap.parse_args(argv)
    run, shipped = load_shipped(a.shipped)
    want = (
        {int(x) for x in a.only.split(",")}
        if a.only
        else {c["condition"]["index"] for c in shipped if c["oscillating"]}
    )
    conds = [c["condition"] for c in only(shipped, want)]
    with ProcessPoolExecutor(a.workers) as ex:
        rows = list(ex.map(touches_by_round, conds, [a.gains] * len(conds)))
    out = {**summarise(rows), "gains": a.gains, "limit": OSCILLATION_LIMIT, "conditions": rows}
    for r in rows:
        marks = " ".join(
            f"r{t['round']}:{t['object']}:{t['ratio']:.2f}{'*' if t['oscillating'] else ''}"
            for t in r["touches"]
        )
        print(f"{r['index']:4d}  {marks}")
    print({k: v for k, v in out.items() if k != "conditions"})
    write_results(a.out, out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
