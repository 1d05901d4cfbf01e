"""An experiment for issue 22, not a shipped controller: the envelope matrix with the probe's flux loop on.

``python -m bench.envelope_probe_flux [--kpQ A/W] [--kiQ A/(W·s)] [--deadband W] [--workers N] [--only I,J]``
writes ``bench/results/envelope_probe_flux.json``. ``--bound delay`` (with ``--only check`` for the subset
below) writes ``bench/results/envelope_probe_flux_bounded.json`` instead: the same loop and deadband with its
gains bounded by the delay margin of the identified loop (:mod:`telethermo.control.flux_bound`: kpQ from the
identified model and the condition's one-way delay, kiQ's zero a decade below the crossover);
``--bound delay-kp`` bounds kpQ alike but keeps kiQ at the candidate's ratio to kpQ
(``..._bounded_kp.json``); ``--bound zero`` is the bound at no delay whatever the condition's (the
candidate's kpQ, kiQ's zero a decade below: ``..._bounded_zero.json``), to tell the delay from the zero.
``--settle S`` schedules the flux integral instead of sizing it: the candidate's gains, but the flux error
charges the integrator only after S s of uninterrupted contact (the proportional part acts from the touch on;
``..._settle.json``).

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
import random
import statistics
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from bench.common import RESULTS_DIR, write_results
from bench.envelope_candidate import add_matrix_args, condition_row, load_shipped, only
from telethermo.control import core_stages
from telethermo.control.flux_bound import flux_gain_bound
from telethermo.control.gain_rule import linear_plant, reference_plant
from telethermo.control.pi import FluxPIGains
from telethermo.control.defaults import GAINS
from telethermo.control.types import Role
from telethermo.offline import envelope

SHIPPED_SLAVE_KP = GAINS[Role.SLAVE]["kp_A_per_C"]  # 0.43 A/°C
_identified = envelope.identified_params
_request = core_stages._telepresence_request
_fit_gains = envelope.fit_gains
_CANDIDATE: dict[str, Any] = {
    "kpQ": 0.258,
    "kiQ": 0.43,
    "deadband": 2.0,
    "bound": "none",
    "delay_s": 0.0,
    "settle_s": 0.0,
}
_CONTACT_AGE = {"s": 0.0}  # the slave's time in uninterrupted contact, s (one session per process at a time)
_MODELS: dict[Role, Any] = {}  # the last identified model per role (the bound reads the slave's)
_USED: dict[str, float] = {}  # the slave's flux gains of the last condition, A/W and A/(W·s)
#: the check subset of ``--only check``: conditions named in docs/control.md, and how many others to draw
NAMED = (68, 51, 85)
OTHERS, OTHERS_SEED = 20, 22


def _recording_fit_gains(model, role):
    _MODELS[Role(role)] = model
    return _fit_gains(model, role)


def _slave_params(role, *args, **kwargs):
    _MODELS.pop(Role(role), None)
    p, fit = _identified(role, *args, **kwargs)
    if role is Role.SLAVE:
        s = p.kp_A_per_C / SHIPPED_SLAVE_KP
        kpQ, kiQ = _CANDIDATE["kpQ"] * s, _CANDIDATE["kiQ"] * s
        if _CANDIDATE["bound"] != "none":
            model = _MODELS.get(Role.SLAVE)  # None: identify refused, the shipped gains (ρ 1) run
            plant = linear_plant(model) if model is not None else reference_plant()
            delay_s = 0.0 if _CANDIDATE["bound"] == "zero" else _CANDIDATE["delay_s"]
            b = flux_gain_bound(plant, reference_plant(), delay_s, _CANDIDATE["kpQ"], rho=s)
            kpQ, kiQ = b["kpQ_A_per_W"], b["kiQ_A_per_W_s"]
            if _CANDIDATE["bound"] == "delay-kp":  # kiQ keeps the candidate's ratio to kpQ (zero 0.27 Hz)
                kiQ = kpQ * _CANDIDATE["kiQ"] / _CANDIDATE["kpQ"]
        _USED.update(kpQ_A_per_W=kpQ, kiQ_A_per_W_s=kiQ)
        p = dataclasses.replace(p, kpQ_A_per_W=kpQ, kiQ_A_per_W_s=kiQ)
    return p, fit


def _deadband_request(sample, peer, params, state, e, usable):
    r = _request(sample, peer, params, state, e, usable)
    if params.role is Role.SLAVE and math.isfinite(r.eQ):
        r = dataclasses.replace(r, eQ=math.copysign(max(abs(r.eQ) - _CANDIDATE["deadband"], 0.0), r.eQ))
    if params.role is Role.SLAVE and _CANDIDATE["settle_s"] > 0.0:
        _CONTACT_AGE["s"] = _CONTACT_AGE["s"] + params.period_s if e.cst.contact else 0.0
        if _CONTACT_AGE["s"] < _CANDIDATE["settle_s"] and r.fg is not None:
            r = dataclasses.replace(r, fg=FluxPIGains(r.fg.kp_A_per_W, 0.0))
    return r


def _run(job: tuple[dict[str, Any], dict[str, Any]]) -> dict[str, Any]:
    cond, candidate = job
    _CANDIDATE.update(
        {"bound": "none", "settle_s": 0.0, **candidate}, delay_s=float(cond.get("delay_ms", 0.0)) / 1000.0
    )
    _CONTACT_AGE["s"] = 0.0
    envelope.identified_params = _slave_params
    envelope.fit_gains = _recording_fit_gains
    core_stages._telepresence_request = _deadband_request
    row = condition_row(cond, ("headline_C", "early_C", "oscillation_ratio", "oscillating", "cue_order_kept"))
    if _CANDIDATE["bound"] != "none":
        row["slave_flux_gains"] = dict(_USED)
    return row


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


def check_groups(shipped: list[dict[str, Any]], cand: list[dict[str, Any]]) -> dict[str, list[int]]:
    """The check subset for the bounded loop, by group: the conditions the fixed-deadband candidate made
    oscillate, those it cured, :data:`NAMED`, and :data:`OTHERS` drawn (seed :data:`OTHERS_SEED`) from
    the rest."""
    sh = {s["condition"]["index"]: bool(s["oscillating"]) for s in shipped}
    ca = {c["index"]: bool(c["oscillating"]) for c in cand}
    common = sorted(set(sh) & set(ca))
    groups = {
        "newly_oscillating": [i for i in common if ca[i] and not sh[i]],
        "cured": [i for i in common if sh[i] and not ca[i]],
        "named": [i for i in NAMED if i in sh],
    }
    taken = {i for g in groups.values() for i in g}
    rest = [i for i in common if i not in taken]
    groups["others"] = sorted(random.Random(OTHERS_SEED).sample(rest, min(OTHERS, len(rest))))
    return groups


def group_summary(
    groups: dict[str, list[int]],
    shipped: list[dict[str, Any]],
    cand: list[dict[str, Any]],
    bounded: list[dict[str, Any]],
) -> dict[str, Any]:
    """Per group: oscillating conditions and conditions beating the best pad (shipped / fixed-deadband
    candidate / bounded), and the headline change against the shipped run (median, worst; °C)."""
    sh = {s["condition"]["index"]: s for s in shipped}
    runs = {"candidate": {c["index"]: c for c in cand}, "bounded": {c["index"]: c for c in bounded}}
    out: dict[str, Any] = {}
    for name, idx in groups.items():
        idx = [i for i in idx if i in runs["bounded"]]
        g: dict[str, Any] = {"indices": idx, "n": len(idx)}
        g["oscillating"] = {"shipped": sum(bool(sh[i]["oscillating"]) for i in idx)}
        g["beats_best_pad"] = {
            "shipped": sum(sh[i]["headline_C"] < sh[i]["best_pad_headline_C"] for i in idx)
        }
        for run, rows in runs.items():
            g["oscillating"][run] = sum(bool(rows[i]["oscillating"]) for i in idx)
            g["beats_best_pad"][run] = sum(rows[i]["headline_C"] < sh[i]["best_pad_headline_C"] for i in idx)
            ch = [rows[i]["headline_C"] - sh[i]["headline_C"] for i in idx]
            g[f"{run}_headline_change_median_C"] = statistics.median(ch) if ch else None
            g[f"{run}_headline_change_worst_C"] = max(ch) if ch else None
        out[name] = g
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m bench.envelope_probe_flux", description=__doc__.split("\n\n")[0]
    )
    ap.add_argument("--kpQ", type=float, default=0.258, help="slave flux loop kp at the shipped kp, A/W")
    ap.add_argument("--kiQ", type=float, default=0.43, help="slave flux loop ki at the shipped kp, A/(W·s)")
    ap.add_argument("--deadband", type=float, default=2.0, help="flux error the loop ignores, W")
    add_matrix_args(ap, "comma-separated condition indices, or 'check' (see check_groups)")
    ap.add_argument(
        "--bound",
        choices=("none", "delay", "delay-kp", "zero"),
        default="none",
        help="bound the flux gains by the delay margin (delay-kp: kpQ only, kiQ keeps its ratio to kpQ; "
        "zero: the bound at no delay, i.e. the candidate's kpQ with kiQ's zero a decade below)",
    )
    ap.add_argument("--settle", type=float, default=0.0, help="contact time before the flux integral acts, s")
    ap.add_argument("--candidate-run", default=str(RESULTS_DIR / "envelope_probe_flux.json"))
    a = ap.parse_args(argv)
    _, shipped = load_shipped(a.shipped)
    groups = None
    if a.only == "check":
        with open(a.candidate_run, encoding="utf-8") as f:
            cand_rows = json.load(f)["conditions"]
        groups = check_groups(shipped, cand_rows)
        want = {i for g in groups.values() for i in g}
    elif a.only:
        want = {int(i) for i in a.only.split(",")}
    if a.only:
        shipped = only(shipped, want)
    candidate = {"kpQ": a.kpQ, "kiQ": a.kiQ, "deadband": a.deadband}
    if a.bound != "none":
        candidate["bound"] = a.bound
    if a.settle > 0.0:
        candidate["settle_s"] = a.settle
    jobs = [(c["condition"], candidate) for c in shipped]
    if a.bound != "none" or a.settle > 0.0:  # the base scene: its headline must stay <= 1.255 °C (issue 22)
        jobs.append((dataclasses.asdict(envelope.base_condition()), candidate))
    with ProcessPoolExecutor(max_workers=a.workers) as ex:
        cand = list(ex.map(_run, jobs))
    base = [r for r in cand if r["index"] == -1]
    cand = [r for r in cand if r["index"] != -1]
    data = {"candidate": candidate, **summary(shipped, cand)}
    if a.bound != "none" or a.settle > 0.0:  # "candidate" names the fixed-deadband run in groups
        data = {k.replace("candidate_", "bounded_", 1): v for k, v in data.items()}
    if base:
        data["base"] = base[0]
    if groups is not None:
        data["groups"] = group_summary(groups, shipped, cand_rows, cand)
    data["conditions"] = cand
    suffix = {"none": "", "delay": "_bounded", "delay-kp": "_bounded_kp", "zero": "_bounded_zero"}[a.bound]
    suffix += f"_settle{a.settle:g}" if a.settle > 0.0 else ""
    path = write_results("envelope_probe_flux" + suffix, data)
    print(json.dumps({k: v for k, v in data.items() if k != "conditions"}, indent=1))
    print(f"written {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
