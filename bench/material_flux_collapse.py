"""Where the refined answer turns a collapsing flux into "unknown" (issue 23): the measurement behind
telethermo.control.material_trust.FLUX_COLLAPSE_MAX.

``python -m bench.material_flux_collapse [--refs CACHE.npz] [--references N] [--touches N]`` computes
:func:`~telethermo.control.material_trust.flux_collapse` (the flux's peak change over its mean change at
0.35–0.45 s) on the envelope classifier's reference touches (read from ``--refs``, the cache
``python -m bench.material_envelope_calibrate --refs`` keeps, else the first ``--references`` simulated
again) and on N (400) development touches beyond the envelope (material_touches.OUTSIDE_DEVELOPMENT, 80 per
kind), and prints per threshold how many references exceed it (the price: refined answers turned away inside
the envelope) and the share of each kind beyond the envelope that does (the detection). Neither set meets
the bench's evaluation seeds. Writes bench/results/material_flux_collapse.json.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from telethermo.atomic import write_json_atomic
from telethermo.control import material_id as mi
from telethermo.control.material_trust import FLUX_COLLAPSE_MAX, flux_collapse
from telethermo.offline import material_envelope_refs as mer
from telethermo.offline import material_touches as mt
from telethermo.offline.material_envelope_calibration import LATE

THRESHOLDS = (3.0, 4.0, 5.0, 6.0, 8.0, 10.0)
RESULT = Path(__file__).resolve().parent / "results" / "material_flux_collapse.json"


def ratios(T: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """flux_collapse of each record (touches × samples, contact at KEEP_PRE) over the refined window; NaN
    where it does not judge."""
    probe = replace(mi.ProbeParams(), window_s=LATE[0])
    out = np.full(len(T), np.nan)
    for k in range(len(T)):
        inp = mi.fit_input(T[k], Q[k], mer.KEEP_PRE, mt.PERIOD_S, probe)
        r = flux_collapse(inp) if inp is not None else None
        if r is not None:
            out[k] = r
    return out


def references(refs: Path | None, n: int) -> dict[str, np.ndarray]:
    if refs is not None:
        with np.load(refs) as f:
            return {k: f[k][:n] for k in ("T", "Q", "thickness_m")}
    return mer.reference_set(n, mer.ENV_REFERENCES, jobs=2)


def outside(n: int) -> tuple[np.ndarray, list[str]]:
    rigs = mer.rig_family()
    kept = [
        (d, mer.reference_touch(rigs, d | {"rig": 0})) for d in mt.outside_draws(n, mt.OUTSIDE_DEVELOPMENT)
    ]
    kept = [(d, r) for d, r in kept if r is not None]
    T = np.array([r[0] for _, r in kept])
    Q = np.array([r[1] for _, r in kept])
    return ratios(T, Q), [d["kind"] for d, _ in kept]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.material_flux_collapse", description=__doc__)
    ap.add_argument("--refs", type=Path, help="the reference touches' cache (.npz)")
    ap.add_argument("--references", type=int, default=mer.ENV_REFERENCES_N)
    ap.add_argument("--touches", type=int, default=400)
    args = ap.parse_args(argv)
    ref = references(args.refs, args.references)
    r_ref = ratios(ref["T"], ref["Q"])
    thin = ref["thickness_m"] < 0.5e-3
    r_out, kinds = outside(args.touches)
    judged = np.isfinite(r_ref)
    rows = []
    for thr in THRESHOLDS:
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
        mark = "  <- FLUX_COLLAPSE_MAX" if thr == FLUX_COLLAPSE_MAX else ""
        print(
            f"> {thr:4.1f}: references {row['references_over']:4d} of {len(r_ref)} "
            f"(thin < 0.5 mm {row['references_over_thin_lt_0p5mm']}); beyond the envelope "
            + ", ".join(f"{k} {v:.2f}" for k, v in row["outside_flagged"].items())
            + mark
        )
    out = {
        "references_n": int(len(r_ref)),
        "references_judged_fraction": round(float(judged.mean()), 3),
        "references_ratio_percentiles_50_99_99p9_max": [
            round(float(v), 2) for v in np.percentile(r_ref[judged], [50, 99, 99.9, 100])
        ],
        "outside_n": len(kinds),
        "flux_collapse_max": FLUX_COLLAPSE_MAX,
        "thresholds": rows,
    }
    write_json_atomic(RESULT, out)
    print(json.dumps({k: v for k, v in out.items() if k != "thresholds"}))
    print(f"wrote {RESULT}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
