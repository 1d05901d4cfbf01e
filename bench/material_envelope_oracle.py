"""The envelope bench's oracle, per answer (bench/material_id_envelope.py): how well any method could name
the touch from what each answer sees, and the pairs no method can tell apart in that time.

The oracle is telethermo/offline/material_oracle.py's unknown-nuisance one (it knows the simulator; the
object's temperature, the contact resistance and the thickness are profiled out per candidate; the probe's
core runs the gains the slave runs, after ``identify`` on another module), run over each answer's own
window: the early answer's (:func:`windows`: the early classifier's 0.42 s) and the refined answer's
(1.2 s). Until the thirty-ninth session one 0.3 s oracle stood beside both answers, which understated what
the refined answer leaves on the table.

Pairs (and, joined transitively, groups) of materials the oracle confuses with a mutual rate ≥
``material_id_bench.MERGE_RATE`` over the envelope's touches outside the near band cannot be told apart
through this probe in that time (issue 23): the accuracy with them merged is reported beside the
accuracy, never instead.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from bench import material_id_bench as mb
from telethermo.control.material_stream import MaterialIdParams, early_samples, late_samples
from telethermo.offline.material_oracle import noise_scale, oracle_answers, touch_candidates
from telethermo.offline.material_touches import noise_of

#: noise draws per touch and answer; the sample: every ORACLE_EVERY-th block of ten touches (one a material)
ORACLE_DRAWS, ORACLE_EVERY = 100, 4
#: the answers (row keys of bench/material_id_envelope.run_touch: answer, posterior) per oracle stage
STAGES = {"late": "answer", "early": "answer_early"}


def oracle_sampled(i: int, k: int) -> bool:
    """Whether touch ``i`` (material i mod ``k``) is in the oracle's sample: every ORACLE_EVERY-th block of
    ``k`` consecutive touches, so that every material is (until the thirty-ninth session every 4th touch:
    the five materials of even index only)."""
    return (i // k) % ORACLE_EVERY == 0


def oracle_note() -> str:
    """What the oracle figures are, for the results file."""
    return (
        f"every {ORACLE_EVERY}th block of ten touches (each material once) and all of the near band, "
        f"{ORACLE_DRAWS} noise draws, over each answer's window (s: {windows()}); the stratum's oracle is "
        "the refined answer's, early.oracle the early answer's; local (nuisances linearised about the "
        "touch's own: optimistic, bench/material_oracle_global.py measures by how much)"
    )


def windows(p: MaterialIdParams | None = None) -> dict[str, float]:
    """Each answer's window, s: the samples after contact its classifier sees (material_stream)."""
    p = p or MaterialIdParams()
    return {
        "early": early_samples(p, mb.PERIOD_S) * mb.PERIOD_S,
        "late": (late_samples(p, mb.PERIOD_S) or early_samples(p, mb.PERIOD_S)) * mb.PERIOD_S,
    }


def oracle_counts(
    rigs: dict, cores: dict, t: dict, sims: list[str], rng: np.random.Generator, window_s: float
) -> list[int]:
    """How often the unknown-nuisance oracle names each of ``sims`` over :data:`ORACLE_DRAWS` noise draws of
    touch ``t`` (its noise × noise_x), seeing ``window_s`` (s) of contact."""
    n_win = int(round(window_s / mb.PERIOD_S))
    sigma = noise_scale(noise_of(t["noise_x"]), n_win)
    z, G = touch_candidates(
        rigs[t["other_tem"]],
        sims,
        t,
        t["T_probe_C"],
        mb.PERIOD_S,
        t["ambient_C"],
        sigma,
        window_s,
        cores.get(t["other_tem"]),
    )
    return np.bincount(oracle_answers(z, G, t["class"], rng, ORACLE_DRAWS)[1], minlength=len(sims)).tolist()


def add_oracle(rows: list[dict], rigs: dict, cores: dict, sims: list[str], seed: int) -> None:
    """Per row, each stage's oracle counts (``oracle_counts_<stage>``) and accuracy (``oracle``: the
    refined answer's, ``oracle_early``)."""
    rng = np.random.default_rng(seed)
    for r in rows:
        for stage, w in windows().items():
            c = oracle_counts(rigs, cores, r, sims, rng, w)
            r[f"oracle_counts_{stage}"] = c
            r["oracle" if stage == "late" else "oracle_early"] = c[r["class"]] / sum(c)


def merged_figures(rows: list[dict], names: list[str]) -> dict[str, Any]:
    """Per stage: the oracle's confusion over ``rows`` that have it, the groups it cannot tell apart (mutual
    confusion ≥ ``material_id_bench.MERGE_RATE``), and over all ``rows`` the answer's accuracy with those
    groups merged (abstains wrong), beside its accuracy and the oracle's, each merged and not."""
    out: dict[str, Any] = {}
    k = len(names)
    truth = np.array([r["class"] for r in rows])
    for stage, a_key in STAGES.items():
        with_o = [r for r in rows if r.get(f"oracle_counts_{stage}") is not None]
        if not with_o:
            continue
        conf = np.zeros((k, k))
        for r in with_o:
            conf[r["class"]] += np.array(r[f"oracle_counts_{stage}"]) / ORACLE_DRAWS
        groups = mb.merged_groups(conf, mb.MERGE_RATE)
        group_of = np.array([next(gi for gi, g in enumerate(groups) if c in g) for c in range(k)])
        ans = np.array([r[a_key] for r in rows])
        named = ans >= 0
        same = np.zeros(len(rows), bool)
        same[named] = group_of[ans[named]] == group_of[truth[named]]
        o_merged = [
            sum(r[f"oracle_counts_{stage}"][j] for j in range(k) if group_of[j] == group_of[r["class"]])
            / ORACLE_DRAWS
            for r in with_o
        ]
        rates = conf / np.maximum(conf.sum(axis=1, keepdims=True), 1e-9)
        out[stage] = {
            "window_s": round(windows()[stage], 3),
            "merged_groups": [[names[c] for c in g] for g in groups if len(g) > 1],
            "accuracy": round(float(np.mean(ans == truth)), 3),
            "accuracy_merged": round(float(np.mean(same)), 3),
            "oracle": round(float(np.trace(conf) / len(with_o)), 3),
            "oracle_merged": round(float(np.mean(o_merged)), 3),
            "oracle_n": len(with_o),
            "oracle_confusion_rows_truth_cols_named": np.round(rates, 3).tolist(),
        }
    return out | {
        "labels": names,
        "merge_rule": f"materials whose mutual confusion by the stage's oracle is >= {mb.MERGE_RATE} over "
        "these touches, joined transitively; accuracy_merged counts an answer right within its truth's group",
    }


def merged_keys(rows: list[dict], names: list[str]) -> dict[str, Any]:
    """Issue 23's merged figures beside the accuracy (:func:`merged_figures`) over ``rows``, the touches
    outside the near band; none where no oracle ran (the quick run)."""
    m = merged_figures(rows, names)
    if "late" not in m:
        return {}
    return {
        "material_id_envelope_oracle_late": m["late"]["oracle"],
        "material_id_envelope_oracle_early": m["early"]["oracle"],
        "material_id_envelope_merged_groups": m["late"]["merged_groups"],
        "material_id_envelope_accuracy_late_merged": m["late"]["accuracy_merged"],
        "material_id_envelope_accuracy_early_merged": m["early"]["accuracy_merged"],
        "material_id_envelope_merged": m,
    }
