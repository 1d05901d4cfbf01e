"""Where the refined and the early answer turn a collapsing flux into "unknown" (issue 23): the measurement
behind telethermo.control.material_trust.FLUX_COLLAPSE_MAX and FLUX_COLLAPSE_MAX_EARLY.

``python -m bench.material_flux_collapse [--refs CACHE.npz] [--references N] [--touches N] [--jobs N]``
computes :func:`~telethermo.control.material_trust.flux_collapse` (the flux's peak change over its mean change
at 0.35–0.45 s for the refined answer, 0.20–0.28 s for the early one) on the envelope classifier's reference
touches (read from ``--refs``, the cache ``python -m bench.material_envelope_calibrate --refs`` keeps, else
the first ``--references`` simulated again) and on N (400) development touches beyond the envelope
(material_touches.OUTSIDE_DEVELOPMENT, 80 per kind), and prints per threshold how many references exceed it
(the price: answers turned away inside the envelope) and the share of each kind beyond the envelope that
does (the detection). Neither set meets the bench's evaluation seeds. Writes
bench/results/material_flux_collapse.json.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from telethermo.atomic import write_json_atomic
from telethermo.control import material_id as mi
from telethermo.control.material_trust import (
    FLUX_COLLAPSE_MAX,
    FLUX_COLLAPSE_MAX_EARLY,
    FLUX_EARLY_LATER_S,
    FLUX_LATER_S,
    flux_collapse,
)
from telethermo.offline import material_envelope_refs as mer
from telethermo.offline import material_touches as mt
from telethermo.offline.material_envelope_calibration import LATE

#: the early window the slave checks a collapse on: the physics fit's, s (the early classifier's is longer)
EARLY_S = mi.ProbeParams().window_s
#: (answer, its window s, the later window s, the shipped threshold, the thresholds measured)
ANSWERS = (
    ("refined", LATE[0], FLUX_LATER_S, FLUX_COLLAPSE_MAX, (3.0, 4.0, 5.0, 6.0, 8.0, 10.0)),
    ("early", EARLY_S, FLUX_EARLY_LATER_S, FLUX_COLLAPSE_MAX_EARLY, (2.0, 2.2, 2.5, 2.8, 3.0)),
)
RESULT = Path(__file__).resolve().parent / "results" / "material_flux_collapse.json"


def ratios(T: np.ndarray, Q: np.ndarray, window_s: float, later_s: tuple[float, float]) -> np.ndarray:
    """flux_collapse (later window ``later_s``) of each record (touches × samples, contact at KEEP_PRE) over
    an answer's window ``window_s``; NaN where it does not judge."""
    probe = replace(mi.ProbeParams(), window_s=window_s)
    out = np.full(len(T), np.nan)
    for k in range(len(T)):
        inp = mi.fit_input(T[k], Q[k], mer.KEEP_PRE, mt.PERIOD_S, probe)
        r = flux_collapse(inp, later_s) if inp is not None else None
        if r is not None:
            out[k] = r
    return out


def references(refs: Path | None, n: int, jobs: int = 2) -> dict[str, np.ndarray]:
    """The first ``n`` reference touches: from the cache ``refs``, else simulated in ``jobs`` processes
    (the same touches whatever ``jobs``)."""
    if refs is not None:
        with np.load(refs) as f:
            return {k: f[k][:n] for k in ("T", "Q", "thickness_m")}
    return mer.reference_set(n, mer.ENV_REFERENCES, jobs=jobs)


def outside(n: int) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """(T, Q, kind) of ``n`` development touches beyond the envelope (the shipped probe)."""
    rigs = mer.rig_family()
    kept = [
        (d, mer.reference_touch(rigs, d | {"rig": 0})) for d in mt.outside_draws(n, mt.OUTSIDE_DEVELOPMENT)
    ]
    kept = [(d, r) for d, r in kept if r is not None]
    return np.array([r[0] for _, r in kept]), np.array([r[1] for _, r in kept]), [d["kind"] for d, _ in kept]


def table(ref: dict[str, np.ndarray], out: tuple[np.ndarray, np.ndarray, list[str]], answer: tuple) -> dict:
    """One answer's measurement: the references' ratios and, per threshold, what it costs and detects."""
    name, window_s, later_s, shipped, thresholds = answer
    r_ref = ratios(ref["T"], ref["Q"], window_s, later_s)
    thin = ref["thickness_m"] < 0.5e-3
    T_out, Q_out, kinds = out
    r_out = ratios(T_out, Q_out, window_s, later_s)
    judged = np.isfinite(r_ref)
    rows = []
    print(f"{name} answer (window {window_s} s, later {later_s[0]}-{later_s[1]} s):")
    for thr in thresholds:
        row = {
            "threshold": thr,
            "references_over": int(np.sum(r_ref[judged] > thr)),
            "references_over_thin_lt_0p5mm": int(np.sum(r_ref[judged & thin] > thr)),
            "outside_flagged": {
                k: round(float(np.mean([r > thr for r, kk in zip(r_out, kinds) if kk == k])), 3)
                for k in sorted(set(kinds))
            },
        }
        rows.append(row)
        mark = "  <- shipped" if thr == shipped else ""
        print(
            f"  > {thr:4.1f}: references {row['references_over']:4d} of {len(r_ref)} "
            f"(thin < 0.5 mm {row['references_over_thin_lt_0p5mm']}); beyond the envelope "
            + ", ".join(f"{k} {v:.2f}" for k, v in row["outside_flagged"].items())
            + mark
        )
    return {
        "window_s": window_s,
        "later_s": list(later_s),
        "shipped_threshold": shipped,
        "references_judged_fraction": round(float(judged.mean()), 3),
        "references_ratio_percentiles_50_99_99p9_max": [
            round(float(v), 2) for v in np.percentile(r_ref[judged], [50, 99, 99.9, 100])
        ],
        "thresholds": rows,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.material_flux_collapse", description=__doc__)
    ap.add_argument("--refs", type=Path, help="the reference touches' cache (.npz)")
    ap.add_argument("--references", type=int, default=mer.ENV_REFERENCES_N)
    ap.add_argument("--touches", type=int, default=400)
    ap.add_argument("--jobs", type=int, default=2, help="simulating processes without --refs (default 2)")
    args = ap.parse_args(argv)
    if args.jobs < 1:
        ap.error(f"--jobs: expected a whole number >= 1, got {args.jobs}")
    ref = references(args.refs, args.references, args.jobs)
    beyond = outside(args.touches)
    out = {
        "references_n": int(len(ref["T"])),
        "outside_n": len(beyond[2]),
        **{a[0]: table(ref, beyond, a) for a in ANSWERS},
    }
    write_json_atomic(RESULT, out)
    print(json.dumps({k: v for k, v in out.items() if not isinstance(v, dict)}))
    print(f"wrote {RESULT}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
