"""The envelope oracle's nuisances fitted for real, on the record the slave saw (issue 23).

``python -m bench.material_oracle_profiled [--n N] [--workers W]`` writes
``bench/results/material_oracle_profiled.json``.

The oracles beside issue 23's figures (bench/material_envelope_oracle.py, bench/material_oracle_global.py)
profile each candidate's object temperature, force and thickness in a linearisation (one projection onto the
span of its trace's sensitivities, about the touch's own values or a pseudo-true fit) and add white noise to
the unfiltered signals. This bench asks what the generalised likelihood-ratio test that *knows the
simulator* reaches when the nuisances are fitted for real (telethermo/offline/material_profile.py:
Levenberg–Marquardt on simulated traces, bounded to the envelope), on the very record the slave classified
(filtered, noisy, closed loop; whitened by the covariance of its noise), on the touches of
bench/material_oracle_global.py (every 20th block of ten of the envelope's evaluation draws, outside the
near band). Per candidate the fit starts at the touch's own nuisances and, for a wrong candidate, also at
its pseudo-true fit from bench/results/material_oracle_global.json when that file holds it; the answer's
window is each answer's own (early 0.34 s, refined 1.2 s). Three classifiers on the same record, paired with
the slave's answer:

- ``linearised``: one projection from the touch's own nuisances (the local oracle's form, on this record);
- ``profiled_known_onset``: the fit, the touch's onset known within its sample (kind: the slave does not
  know where in the 10 ms sample the contact began);
- ``profiled``: the same fit continued with the onset free too (within ± one sample): the reference;
- ``laplace``: that fit's evidence by Laplace's approximation (telethermo/offline/material_profile.py,
  ``laplace_log_evidence``): a wrong material that fits only on a narrow ridge of its nuisances is weighed by
  how narrow, as the posterior marginalised over the envelope's flat prior would, which the maximum
  likelihood does not.

Each still knows the simulator (one contact law for every surface, the back condition), the probe's rig,
its gains, its resting state and the room: a ceiling for a method that must learn the probe from examples.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from bench import material_id_bench as mb
from bench.common import write_results
from bench.material_envelope_oracle import windows
from bench.material_id_envelope import after_identify, run_touch, simulate_drawn
from bench.material_oracle_global import by_stratum, paired_gap, touches
from telethermo.offline.material_profile import (
    KNOWN_ONSET,
    TouchModel,
    laplace_log_evidence,
    lm_fit,
    noise_covariance,
    record_vector,
    whitening,
    window_block,
    with_onset_free,
)
from telethermo.offline.material_touches import ENVELOPE_N, SIM_TO_TABLE, other_tem
from telethermo.sim.tem import load_rig_params

#: Levenberg–Marquardt iterations with the onset known, then with it free too
ITERS, ONSET_ITERS = 4, 2
#: paired noisy and noise-free touches per module for the noise covariance
NOISE_PAIRS = 1500
GLOBAL = Path(__file__).resolve().parent / "results" / "material_oracle_global.json"
KINDS = ("linearised", "profiled_known_onset", "profiled", "laplace")

_WORKER: dict[str, Any] = {}


def _rigs() -> tuple[dict, dict]:
    base = load_rig_params()
    rigs = {False: base, True: other_tem(base)}
    return rigs, {False: None, True: after_identify(rigs[True])}


def _cov(rig: tuple[Any, Any]) -> np.ndarray:
    params, core = rig
    n_full = int(round(max(windows().values()) / mb.PERIOD_S))
    return noise_covariance(params, core, list(SIM_TO_TABLE), NOISE_PAIRS, n_full, seed=77)


def _init(rigs: dict, cores: dict, covs: dict) -> None:
    _WORKER.update(rigs=rigs, cores=cores, covs=covs, sims=list(SIM_TO_TABLE))


def _starts(t: dict, j: int, pseudo: list[dict] | None) -> list[np.ndarray]:
    own = np.array([math.log(t["force_N"]), math.log(t["thickness_m"]), t["T_object_C"], 0.0])
    out = [own]
    if j != t["class"] and pseudo:
        p = next((q for q in pseudo if q["material"] == list(SIM_TO_TABLE)[j]), None)
        if p is not None:
            out.append(
                np.array([math.log(p["force_N"]), math.log(p["thickness_mm"] * 1e-3), p["T_o_C"], 0.0])
            )
    return out


def score_touch(t: dict) -> dict[str, Any]:
    """Each classifier's residual per candidate on touch ``t``'s record, per answer's window, and the slave's
    answers."""
    rigs, cores, sims = _WORKER["rigs"], _WORKER["cores"], _WORKER["sims"]
    names = [mb.SIM_TO_TABLE[m] for m in sims]
    T, Q, i0, _, _ = simulate_drawn(rigs, t, sims, cores)
    c0 = time.process_time()
    slave = run_touch(rigs, t, sims, names, cores)
    c1 = time.process_time()
    n_full = int(round(max(windows().values()) / mb.PERIOD_S))
    out: dict[str, Any] = {k: t[k] for k in ("class", "T_object_C", "force_N", "thickness_m", "ambient_C")}
    out |= {"noise_x": t["noise_x"], "other_tem": t["other_tem"], "T_probe_C": t["T_probe_C"]}
    out["answer"] = {"late": slave["answer"], "early": slave["answer_early"]}
    for stage, w in windows().items():
        n_win = int(round(w / mb.PERIOD_S))
        v = record_vector(T, Q, i0, n_win)
        if v is None:
            out[stage] = None
            continue
        W = whitening(window_block(_WORKER["covs"][t["other_tem"]], n_full, n_win), t["noise_x"])
        model = TouchModel(
            rigs[t["other_tem"]],
            cores[t["other_tem"]],
            t["ambient_C"],
            t["T_probe_C"],
            t["t_on_s"],
            i0,
            n_win,
            W,
        )
        x = W @ v
        res: dict[str, list[float]] = {k: [] for k in KINDS}
        sims_run = 0
        for j, mat in enumerate(sims):
            fits = [
                lm_fit(lambda th, m=mat: model.trace(m, th), x, s, KNOWN_ONSET, ITERS)
                for s in _starts(t, j, (t.get("pseudo") or {}).get(stage))
            ]
            best = min(fits, key=lambda f: f.cost)
            free = lm_fit(
                lambda th, m=mat: model.trace(m, th), x, best.theta, with_onset_free(KNOWN_ONSET), ONSET_ITERS
            )
            sims_run += sum(f.sims for f in fits) + free.sims
            res["linearised"].append(fits[0].linearised)
            res["profiled_known_onset"].append(best.cost)
            res["profiled"].append(free.cost)
            res["laplace"].append(-2.0 * laplace_log_evidence(free))
        out[stage] = res | {"sims": sims_run}
    # CPU of the profiled fits over that of the slave's whole touch (its control and classification), same
    # process: what the reference would cost the node
    out["fit_cpu_over_touch"] = (time.process_time() - c1) / max(c1 - c0, 1e-9)
    return out


def _pseudo(ts: list[dict]) -> None:
    """Attach each touch's pseudo-true fits (per stage) from the global oracle's results, where it holds the
    same touches in the same order."""
    if not GLOBAL.exists():
        return
    rows = json.loads(GLOBAL.read_text())["touches"]
    if len(rows) != len(ts):
        return
    for t, r in zip(ts, rows):
        if r["class"] == t["class"] and abs(r["T_object_C"] - t["T_object_C"]) < 1e-9:
            t["pseudo"] = {s: r[s]["pseudo_true"] for s in ("late", "early") if s in r}


def summarise(rows: list[dict]) -> dict[str, Any]:
    """Per window, over all touches and per stratum: each classifier's accuracy, the slave's, the paired gap
    of the slave to the profiled one with its standard error."""
    out: dict[str, Any] = {}
    for stage in windows():
        ok = [r for r in rows if r.get(stage)]

        def one(rs: list[dict], st: str = stage) -> dict[str, Any]:
            if not rs:
                return {"n": 0}
            got = {k: np.array([float(np.argmin(r[st][k]) == r["class"]) for r in rs]) for k in KINDS}
            ans = np.array([float(r["answer"][st] == r["class"]) for r in rs])
            return (
                {"n": len(rs), "answer": round(float(ans.mean()), 3)}
                | {k: round(float(v.mean()), 3) for k, v in got.items()}
                | paired_gap(got["profiled"], ans, "gap_to_profiled")
            )

        out[stage] = by_stratum(ok, one)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--n", type=int, default=ENVELOPE_N, help="envelope touches drawn (every 20th block scored)"
    )
    ap.add_argument("--workers", type=int, default=2)
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    ts = touches(a.n)
    _pseudo(ts)
    rigs, cores = _rigs()  # the other module identified once, for every process
    with ProcessPoolExecutor(a.workers) as ex:
        covs = dict(zip((False, True), ex.map(_cov, [(rigs[k], cores[k]) for k in (False, True)])))
    with ProcessPoolExecutor(a.workers, initializer=_init, initargs=(rigs, cores, covs)) as ex:
        rows = list(ex.map(score_touch, ts))
    summary = summarise(rows)
    top = {s: summary[s]["all_outside_near_band"] for s in summary}
    res: dict[str, Any] = {"material_oracle_profiled_n_touches": len(rows)}
    for s in ("late", "early"):
        res |= {
            f"material_oracle_profiled_{s}": top[s]["profiled"],
            f"material_oracle_profiled_known_onset_{s}": top[s]["profiled_known_onset"],
            f"material_oracle_linearised_record_{s}": top[s]["linearised"],
            f"material_oracle_profiled_answer_{s}": top[s]["answer"],
            f"material_oracle_profiled_gap_{s}": top[s]["gap_to_profiled"],
            f"material_oracle_laplace_{s}": top[s]["laplace"],
        }
    res |= {
        "pseudo_true_starts": sum(1 for t in ts if t.get("pseudo")),
        "fit_cpu_over_slave_touch_median": round(
            float(np.median([r["fit_cpu_over_touch"] for r in rows])), 1
        ),
        "sims_per_touch_median": {
            s: float(np.median([r[s]["sims"] for r in rows if r.get(s)])) for s in ("late", "early")
        },
        "strata": summary,
        "windows_s": windows(),
        "settings": {"iters": ITERS, "onset_iters": ONSET_ITERS, "noise_pairs": NOISE_PAIRS},
        "touches": rows,
        "method": __doc__,
        "run_s": round(time.perf_counter() - t0, 1),
    }
    write_results("material_oracle_profiled", res)
    for stage, st in summary.items():
        for k, v in st.items():
            print(f"{stage:5} {k:36} " + "  ".join(f"{kk} {vv}" for kk, vv in v.items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
