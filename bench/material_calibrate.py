"""Calibrate the slave's material classifier on simulated reference touches (issue 15).

``python -m bench.material_calibrate [--n 40000] [--dense 30000] [--out telethermo/data/material_classifier.npz]``

Reference touches are drawn like the bench's (bench/material_id_bench.py: the ten materials in turn, force
2–10 N, object 15–35 °C, thickness 1–20 mm, noise on, the slave's default controller at rest at the
finger's natural temperature, 10 ms) but with their own seeds (bench.material_id_bench.CALIBRATION), disjoint from the bench's evaluation
touches (draw seed 15, simulator seeds 1000 + i) and from its held-out set (draw seed 2525, simulator seeds
300000 + i): a calibration whose seeds overlap either is refused, here and by the bench. ``--dense`` more
touches of ceramic and the metals at 2–6 N (their own seeds, :data:`DENSE`), where the classes are hardest to
tell apart. Per touch the slave's own touch vector (telethermo.control.material_calib.touch_vector: the
filtered signals of the 0.3 s window from the sample the slave's detector calls contact, no truth) is kept
with its material. The rig's noise covariance in that vector (the first 2000 draws simulated with noise and
without) whitens it. The local model's size k is chosen on the reference touches alone (every fifth
classified by the other four fifths), then the classifier is built on all of them and written atomically.

On hardware the simulator's calibration does not transfer as such: the same fit on touches of the lab's own
reference samples is needed (docs/material_id.md).
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from bench.material_id_bench import (CALIBRATION, PERIOD_S, PRE_S, SIM_TO_TABLE, draws, finger_natural_C,
                                     refuse_overlap, simulate_touch)
from telethermo.control import material_id as mi
from telethermo.control.material_calib import (DEFAULT_CALIBRATION, build_calibration, classify_vector,
                                               save_calibration, touch_vector)
from telethermo.sim.measurement import NoiseParams
from telethermo.sim.tem import load_rig_params

#: the flux's weight in the touch vector, K/W; principal components kept; local model sizes tried
Q_WEIGHT_K_PER_W, COMPONENTS, KS = 3.0, 24, (5, 8, 12)
#: touches simulated twice (noise on and off) for the noise covariance; its floor (material_calib.whitener)
NOISE_TOUCHES, NOISE_FLOOR = 2000, 0.01
#: the extra reference touches' (draw seed, first simulator seed), classes (ceramic and the five metals: the
#: effusivity hides behind the contact resistance, where the local models run out of neighbours) and force range
DENSE, DENSE_CLASSES, DENSE_FORCE_N = (1616, 400_000), (4, 5, 6, 7, 8, 9), 6.0


def touch_record(params, T_probe_C: float, d: dict, noise: NoiseParams | None = None):
    """(T_sensor_C, Q_W, the sample the slave's detector calls contact) of one drawn touch (``noise`` None:
    the rig's default noise), simulated without the core's own identification (the same current)."""
    T, Q, i0, _, _ = simulate_touch(params, list(SIM_TO_TABLE)[d["class"]], d["thickness_m"], d["T_object_C"],
                                    d["force_N"], T_probe_C, seed=d["seed"], t_on_s=d["t_on_s"], noise=noise,
                                    identify=False)
    return T, Q, i0


def vector_of(T: np.ndarray, Q: np.ndarray, i0: int, probe: mi.ProbeParams = mi.ProbeParams()) -> np.ndarray | None:
    """The slave's touch vector of one record (None without a complete window)."""
    inp = mi.fit_input(T, Q, i0, PERIOD_S, probe) if i0 >= 0 else None
    return touch_vector(inp, Q_WEIGHT_K_PER_W) if inp is not None else None


def dense_draws(n: int, seeds: tuple[int, int]) -> list[dict]:
    """``n`` extra reference draws where the classes are hardest to tell apart: the classes of
    :data:`DENSE_CLASSES` in turn, under a contact resistance (force 2–6 N); object temperature, thickness and
    onset as :func:`bench.material_id_bench.draws`."""
    rng = np.random.default_rng(seeds[0])
    out = []
    for i in range(n):
        out.append({"class": DENSE_CLASSES[i % len(DENSE_CLASSES)], "force_N": float(rng.uniform(2.0, DENSE_FORCE_N)),
                    "T_object_C": float(rng.uniform(15.0, 35.0)), "thickness_m": float(rng.uniform(1.0, 20.0)) * 1e-3,
                    "t_on_s": PRE_S + float(rng.uniform(0.0, PERIOD_S)), "seed": seeds[1] + i})
    return out


def reference_set(n: int, seeds: tuple[int, int], log_every: int = 2000, dense: bool = False
                  ) -> tuple[np.ndarray, np.ndarray]:
    """(touch vectors, class indices) of ``n`` reference touches (touches without a window left out); ``dense``:
    drawn by :func:`dense_draws` instead of the bench's distribution."""
    refuse_overlap(n, seeds)
    params = load_rig_params()
    T_probe = finger_natural_C(params)
    V, y = [], []
    for i, d in enumerate(dense_draws(n, seeds) if dense else draws(n, seeds)):
        T, Q, i0 = touch_record(params, T_probe, d)
        v = vector_of(T, Q, i0)
        if v is not None:
            V.append(v)
            y.append(d["class"])
        if log_every and (i + 1) % log_every == 0:
            print(f"  {i + 1}/{n} reference touches")
    return np.array(V), np.array(y)


def noise_covariance(n: int, seeds: tuple[int, int]) -> np.ndarray:
    """Covariance (°C², 2·n_win square) of the touch vector's noise: the first ``n`` reference draws simulated
    with the rig's noise and without it, both windows taken at the noisy touch's onset (what the slave sees;
    the difference also carries the controller's response to the noise)."""
    params = load_rig_params()
    T_probe = finger_natural_C(params)
    D = []
    for d in draws(n, seeds):
        T, Q, i0 = touch_record(params, T_probe, d)
        Tc, Qc, _ = touch_record(params, T_probe, d, NoiseParams(enabled=False))
        v, vc = vector_of(T, Q, i0), vector_of(Tc, Qc, i0)
        if v is not None and vc is not None:
            D.append(v - vc)
    return np.cov(np.array(D).T)


def choose_k(V: np.ndarray, y: np.ndarray, classes: list[str], noise_cov: np.ndarray) -> tuple[int, dict]:
    """k with the best accuracy on every fifth reference touch, built on the other four fifths (interleaved:
    the dense references come last, a final fifth would be only those)."""
    val = np.arange(len(y)) % 5 == 4
    scores = {}
    for k in KS:
        cal = build_calibration(V[~val], y[~val], classes, PERIOD_S, Q_WEIGHT_K_PER_W, k, COMPONENTS,
                                noise_cov=noise_cov, reg=NOISE_FLOOR)
        scores[k] = float(np.mean([classify_vector(cal, v)[0] == c for v, c in zip(V[val], y[val])]))
    return max(scores, key=scores.get), scores


def calibrate(n: int, out: Path, n_dense: int = 0) -> dict:
    """Simulate ``n`` reference touches (and ``n_dense`` extra ones, :func:`dense_draws`), choose k, build, write
    ``out``; returns what was done."""
    classes = [SIM_TO_TABLE[m] for m in SIM_TO_TABLE]
    V, y = reference_set(n, CALIBRATION)
    if n_dense:
        Vd, yd = reference_set(n_dense, DENSE, dense=True)
        V, y = np.concatenate([V, Vd]), np.concatenate([y, yd])
    S = noise_covariance(min(NOISE_TOUCHES, n), CALIBRATION)
    k, scores = choose_k(V, y, classes, S)
    info = {"reference_touches": int(n), "draw_seed": CALIBRATION[0], "sim_seed_first": CALIBRATION[1],
            "dense": {"touches": int(n_dense), "draw_seed": DENSE[0], "sim_seed_first": DENSE[1],
                      "classes": [classes[c] for c in DENSE_CLASSES], "force_N": [2.0, DENSE_FORCE_N]},
            "references_kept": int(len(y)),
            "period_s": PERIOD_S, "source": "simulated (python -m bench.material_calibrate): force 2-10 N, object "
            "15-35 C, thickness 1-20 mm, noise on, slave default controller, probe at the finger's natural temperature",
            "onset": "the slave's contact detector (as telethermo.control.material_stream)",
            "whitening": {"noise_touches": min(NOISE_TOUCHES, n), "floor": NOISE_FLOOR},
            "validation_accuracy_by_k": {str(a): round(b, 4) for a, b in scores.items()}, "k": k}
    cal = build_calibration(V, y, classes, PERIOD_S, Q_WEIGHT_K_PER_W, k, COMPONENTS, json.dumps(info), S, NOISE_FLOOR)
    save_calibration(cal, out)
    print(f"k {k} (validation accuracy by k, reference touches only: {info['validation_accuracy_by_k']}); wrote {out}")
    return info


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.material_calibrate", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=40000, help="reference touches (default 40000)")
    ap.add_argument("--dense", type=int, default=30000,
                    help="extra reference touches of ceramic and the metals at 2-6 N (default 30000)")
    ap.add_argument("--out", type=Path, default=DEFAULT_CALIBRATION, help="calibration file to write")
    args = ap.parse_args(argv)
    calibrate(args.n, args.out, args.dense)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
