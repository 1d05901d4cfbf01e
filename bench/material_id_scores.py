"""Scores of the material bench's envelope run (bench/material_id_envelope.py): the expected calibration
error and its floor, the figures of the touches beyond the envelope, the fit's slowest cycle position, and
the run's printout, and when each answer is out."""

from __future__ import annotations

from typing import Any

import numpy as np

from telethermo.control.material_stream import (
    MaterialIdParams,
    early_samples,
    fit_units,
    late_fit_units,
    late_samples,
)

# the calibration error and its floors live in the library (the tests use them too); re-exported
from telethermo.offline.calibration_error import ECE_FLOOR_SEED, ece, ece_floor, ece_worst_floor
from telethermo.offline.material_touches import PERIOD_S

__all__ = [
    "CONFIDENT",
    "answer_timing",
    "ECE_FLOOR_SEED",
    "ece",
    "ece_floor",
    "ece_worst_floor",
    "outside_figures",
    "position_worst_ms",
    "print_envelope",
]

#: posterior at and above which an answer counts as confident
CONFIDENT = 0.9


def outside_figures(rows: list[dict]) -> dict[str, Any]:
    """Per kind of condition beyond the envelope and over all: how many answers are "unknown" (refined /
    early), how often the named ones are right, and the confident ones (posterior ≥ 0.9)."""

    def one(rs: list[dict]) -> dict[str, Any]:
        truth = np.array([r["class"] for r in rs])
        out: dict[str, Any] = {"n": len(rs)}
        for stage, a_key, p_key in (
            ("late", "answer", "posterior"),
            ("early", "answer_early", "posterior_early"),
        ):
            ans, post = np.array([r[a_key] for r in rs]), np.array([r[p_key] for r in rs])
            named, conf = ans >= 0, (ans >= 0) & (post >= CONFIDENT)
            out[stage] = {
                "unknown_fraction": round(float(np.mean(~named)), 3),
                "named_accuracy": round(float(np.mean(ans[named] == truth[named])), 3)
                if named.any()
                else None,
                "confident_n": int(conf.sum()),
                "confident_precision": (
                    round(float(np.mean(ans[conf] == truth[conf])), 3) if conf.any() else None
                ),
            }
        return out

    kinds = sorted({r["kind"] for r in rows})
    return {"all": one(rows)} | {k: one([r for r in rows if r["kind"] == k]) for k in kinds}


def position_worst_ms(rows: list[dict]) -> float | None:
    """The slowest cycle position of the early fit: per position after the window the median over touches,
    then the largest. What the work costs, immune to the scheduler's occasional preemption of one cycle
    that a per-touch maximum picks up on a loaded machine."""
    pos = [r["fit_positions_ms"] for r in rows if r["fit_positions_ms"]]
    if not pos:
        return None
    n = min(len(x) for x in pos)
    return float(np.max(np.median(np.array([x[:n] for x in pos]), axis=0)))


def print_envelope(fig: dict[str, Any]) -> None:
    """One line per stratum."""
    cols = (
        "n",
        "accuracy",
        "abstain_fraction",
        "ece",
        "ece_floor",
        "confident_precision",
        "confident_n",
        "baseline_commonest_class",
        "oracle",
    )
    print(f"{'stratum':24s} " + " ".join(f"{c[:12]:>12s}" for c in cols))
    for name, v in list(fig["material_id_envelope_strata"].items()) + [
        ("inbox", fig["material_id_inbox_same_keys"])
    ]:
        print(f"{name:24s} " + " ".join(f"{str(v.get(c)):>12s}" for c in cols))
    print("beyond the envelope (unknown fraction, named accuracy, confident precision (n); refined | early)")
    for kind, v in fig.get("material_id_outside", {}).items():
        cells = [
            f"{s['unknown_fraction']} {s['named_accuracy']} {s['confident_precision']} ({s['confident_n']})"
            for s in (v["late"], v["early"])
        ]
        print(f"  {kind:12s} n {v['n']:4d}: " + " | ".join(cells))
    for k, v in fig.items():
        if not isinstance(v, dict):
            print(f"{k}: {v}")


def answer_timing(early: bool) -> str:
    """When the early (``early``) or the refined answer is out after the contact, and what it is made of."""
    p, dt = MaterialIdParams(), PERIOD_S
    per = p.units_per_cycle
    if early:
        n, cycles = early_samples(p, dt), fit_units(p, dt)
        return (
            f"{(n + cycles) * dt:.2f} s after contact: the early envelope classifier's {n * dt:.2f} s window "
            f"(the physics fit over its first {p.probe.window_s:g} s) + {cycles} fit cycles of {per} units "
            "(in-box network in its box, else the early envelope classifier)"
        )
    n, cycles = late_samples(p, dt), late_fit_units(p)
    return (
        f"{(n + cycles) * dt:.2f} s after contact: the envelope classifiers pooled (the pool's over 0.3 s, "
        f"the refined one over {n * dt:.2f} s) + {cycles} fit cycles of {per} units; in the box the in-box "
        "network's class stands"
    )
