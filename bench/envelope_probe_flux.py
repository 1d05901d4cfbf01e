"""An experiment for issue 22, not a shipped controller: the envelope matrix with the probe's flux loop on.

``python -m bench.envelope_probe_flux [--kpQ A/W] [--kiQ A/(W·s)] [--deadband W] [--workers N] [--only I,J]``
writes ``bench/results/envelope_probe_flux.json``.

docs/control.md traces half the matrix's losses to the best constant pad to the probe following the finger
estimate that a saturated display cannot pull down (condition 68: the probe gives the object 23.4 J where the
finger gives 10.5 J). The candidate measured here: the slave's flux loop towards the mirror of the display's
flux (``kpQ_A_per_W``, ``kiQ_A_per_W_s``, both scaled like its kp by the gain rule's ratio to the shipped
slave kp, so that a module of 2.5× Seebeck does not ring), acting only on the part of the flux error beyond
``deadband`` W (the display delivering the finger's flux within it, the temperature loop alone acts). It runs
the same conditions as bench/results/envelope.json (their parameters are read from it) with the identified
gains and the candidate loop wrapped around the core's telepresence request, and scores them against the
shipped run's own figures in that file (the best pads do not depend on the controller).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import statistics
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from bench.common import RESULTS_DIR, write_results
from telethermo.control import core_stages
from telethermo.control.defaults import GAINS
from telethermo.control.types import Role
from telethermo.offline import envelope

SHIPPED_SLAVE_KP = GAINS[Role.SLAVE]["kp_A_per_C"]  # 0.43 A/°C
_identified = envelope.identified_params
_request = core_stages._telepresence_request
_CANDIDATE = {"kpQ": 0.258, "kiQ": 0.43, "deadband": 2.0}


def _slave_params(role, *args, **kwargs):
    p, fit = _identified(role, *args, **kwargs)
    if role is Role.SLAVE:
        s = p.kp_A_per_C / SHIPPED_SLAVE_KP
        p = dataclasses.replace(p, kpQ_A_per_W=_CANDIDATE["kpQ"] * s, kiQ_A_per_W_s=_CANDIDATE["kiQ"] * s)
    return p, fit


def _deadband_request(sample, peer, params, state, e, usable):
    r = _request(sample, peer, params, state, e, usable)
    if params.role is Role.SLAVE and math.isfinite(r.eQ):
        r = dataclasses.replace(r, eQ=math.copysign(max(abs(r.eQ) - _CANDIDATE["deadband"], 0.0), r.eQ))
    return r


def _run(job: tuple[dict[str, Any], dict[str, float]]) -> dict[str, Any]:
    cond, candidate = job
    _CANDIDATE.update(candidate)
    envelope.identified_params = _slave_params
    core_stages._telepresence_request = _deadband_request
    c = envelope.Condition(**{k: tuple(v) if isinstance(v, list) else v for k, v in cond.items()})
    r = envelope.run_condition(c, with_pads=False)
    keep = ("headline_C", "early_C", "oscillation_ratio", "oscillating", "cue_order_kept", "session_long_cut")
    return {"index": c.index, **{k: r[k] for k in keep}, "trips": len(r["trips"])}


def summary(shipped: list[dict[str, Any]], cand: list[dict[str, Any]]) -> dict[str, Any]:
    """The candidate's matrix figures beside the shipped run's on the same conditions."""
    by = {r["index"]: r for r in cand}
    pairs = [(s, by[s["condition"]["index"]]) for s in shipped if s["condition"]["index"] in by]
    n, fair = len(pairs), [(s, c) for s, c in pairs if s["cue_fair"]]
    out: dict[str, Any] = {"n_conditions": n}
    for name, pick in (("shipped", 0), ("candidate", 1)):
        rows = [p[pick] for p in pairs]
        out[f"{name}_beats_best_pad_fraction"] = sum(
            r["headline_C"] < s["best_pad_headline_C"] for r, (s, _) in zip(rows, pairs)
        ) / max(n, 1)
        out[f"{name}_oscillating_conditions"] = sum(bool(r["oscillating"]) for r in rows)
        out[f"{name}_trips"] = sum(
            len(r["trips"]) if isinstance(r["trips"], list) else r["trips"] for r in rows
        )
        out[f"{name}_session_long_cuts"] = sum(bool(r["session_long_cut"]) for r in rows)
        out[f"{name}_cue_order_kept_fraction"] = sum(bool(p[pick]["cue_order_kept"]) for p in fair) / max(
            len(fair), 1
        )
        ratio = sorted(r["headline_C"] / s["best_pad_headline_C"] for r, (s, _) in zip(rows, pairs))
        out[f"{name}_ratio_to_best_pad_median"] = statistics.median(ratio) if ratio else None
        out[f"{name}_ratio_to_best_pad_p90"] = ratio[max(0, math.ceil(0.9 * n) - 1)] if ratio else None
    change = sorted(c["headline_C"] - s["headline_C"] for s, c in pairs)
    out["headline_change_median_C"] = statistics.median(change) if change else None
    out["headline_change_best_C"], out["headline_change_worst_C"] = (
        (change[0], change[-1]) if change else (None,) * 2
    )
    out["newly_oscillating"] = [
        [s["condition"]["index"], round(s["oscillation_ratio"], 2), round(c["oscillation_ratio"], 2)]
        for s, c in pairs
        if c["oscillating"] and not s["oscillating"]
    ]
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m bench.envelope_probe_flux", description=__doc__.split("\n\n")[0]
    )
    ap.add_argument("--kpQ", type=float, default=0.258, help="slave flux loop kp at the shipped kp, A/W")
    ap.add_argument("--kiQ", type=float, default=0.43, help="slave flux loop ki at the shipped kp, A/(W·s)")
    ap.add_argument("--deadband", type=float, default=2.0, help="flux error the loop ignores, W")
    ap.add_argument("--workers", type=int, default=2, help="processes (default 2)")
    ap.add_argument("--shipped", default=str(RESULTS_DIR / "envelope.json"), help="the shipped run's results")
    ap.add_argument("--only", help="comma-separated condition indices (default: all)")
    a = ap.parse_args(argv)
    with open(a.shipped, encoding="utf-8") as f:
        shipped = [c for c in json.load(f)["conditions"] if "headline_C" in c]
    if a.only:
        want = {int(i) for i in a.only.split(",")}
        shipped = [c for c in shipped if c["condition"]["index"] in want]
    candidate = {"kpQ": a.kpQ, "kiQ": a.kiQ, "deadband": a.deadband}
    with ProcessPoolExecutor(max_workers=a.workers) as ex:
        cand = list(ex.map(_run, [(c["condition"], candidate) for c in shipped]))
    data = {"candidate": candidate, **summary(shipped, cand), "conditions": cand}
    path = write_results("envelope_probe_flux", data)
    print(json.dumps({k: v for k, v in data.items() if k != "conditions"}, indent=1))
    print(f"written {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
