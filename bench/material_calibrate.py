"""Calibrate the slave's material classifier on simulated reference touches (issue 15).

``python -m bench.material_calibrate [--n 20000] [--out telethermo/data/material_classifier.npz]``

Reference touches are drawn like the bench's (bench/material_id_bench.py: the ten materials in turn, force
2–10 N, object 15–35 °C, thickness 1–20 mm, noise on, the slave's default controller at rest at the
finger's natural temperature, 10 ms) but with their own seeds (bench.material_id_bench.CALIBRATION), disjoint from the bench's evaluation
touches (draw seed 15, simulator seeds 1000 + i) and from its held-out set (draw seed 2525, simulator seeds
300000 + i): a calibration whose seeds overlap either is refused, here and by the bench. Per touch the slave's own touch vector
(telethermo.control.material_calib.touch_vector: the filtered signals of the 0.3 s window, no truth) is
kept with its material. The local model's size k is chosen on the reference touches alone (the last fifth
classified by the first four fifths), then the classifier is built on all of them and written atomically.

On hardware the simulator's calibration does not transfer as such: the same fit on touches of the lab's own
reference samples is needed (docs/material_id.md).
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from bench.material_id_bench import (CALIBRATION, PERIOD_S, SIM_TO_TABLE, draws, finger_natural_C, refuse_overlap,
                                     simulate_touch)
from telethermo.control import material_id as mi
from telethermo.control.material_calib import (DEFAULT_CALIBRATION, build_calibration, classify_vector,
                                               save_calibration, touch_vector)
from telethermo.sim.tem import load_rig_params

#: the flux's weight in the touch vector, K/W; principal components kept; local model sizes tried
Q_WEIGHT_K_PER_W, COMPONENTS, KS = 3.0, 24, (5, 8, 12)


def touch_record(params, T_probe_C: float, d: dict):
    """(T_sensor_C, Q_W, first contact sample, the material the slave's core published) of one drawn touch."""
    T, Q, i0, est, _ = simulate_touch(params, list(SIM_TO_TABLE)[d["class"]], d["thickness_m"], d["T_object_C"],
                                      d["force_N"], T_probe_C, seed=d["seed"], t_on_s=d["t_on_s"])
    return T, Q, i0, est


def vector_of(T: np.ndarray, Q: np.ndarray, i0: int, probe: mi.ProbeParams = mi.ProbeParams()) -> np.ndarray | None:
    """The slave's touch vector of one record (None without a complete window)."""
    inp = mi.fit_input(T, Q, i0, PERIOD_S, probe) if i0 >= 0 else None
    return touch_vector(inp, Q_WEIGHT_K_PER_W) if inp is not None else None


def reference_set(n: int, seeds: tuple[int, int], log_every: int = 2000) -> tuple[np.ndarray, np.ndarray]:
    """(touch vectors, class indices) of ``n`` reference touches (touches without a window left out)."""
    refuse_overlap(n, seeds)
    params = load_rig_params()
    T_probe = finger_natural_C(params)
    V, y = [], []
    for i, d in enumerate(draws(n, seeds)):
        T, Q, i0, _ = touch_record(params, T_probe, d)
        v = vector_of(T, Q, i0)
        if v is not None:
            V.append(v)
            y.append(d["class"])
        if log_every and (i + 1) % log_every == 0:
            print(f"  {i + 1}/{n} reference touches")
    return np.array(V), np.array(y)


def choose_k(V: np.ndarray, y: np.ndarray, classes: list[str]) -> tuple[int, dict]:
    """k with the best accuracy on the last fifth of the reference touches, built on the first four fifths."""
    cut = len(y) * 4 // 5
    scores = {}
    for k in KS:
        cal = build_calibration(V[:cut], y[:cut], classes, PERIOD_S, Q_WEIGHT_K_PER_W, k, COMPONENTS)
        scores[k] = float(np.mean([classify_vector(cal, v)[0] == c for v, c in zip(V[cut:], y[cut:])]))
    return max(scores, key=scores.get), scores


def calibrate(n: int, out: Path) -> dict:
    """Simulate ``n`` reference touches, choose k, build, write ``out``; returns what was done."""
    classes = [SIM_TO_TABLE[m] for m in SIM_TO_TABLE]
    V, y = reference_set(n, CALIBRATION)
    k, scores = choose_k(V, y, classes)
    info = {"reference_touches": int(len(y)), "draw_seed": CALIBRATION[0], "sim_seed_first": CALIBRATION[1],
            "period_s": PERIOD_S, "source": "simulated (python -m bench.material_calibrate): force 2-10 N, object "
            "15-35 C, thickness 1-20 mm, noise on, slave default controller, probe at the finger's natural temperature",
            "validation_accuracy_by_k": {str(a): round(b, 4) for a, b in scores.items()}, "k": k}
    cal = build_calibration(V, y, classes, PERIOD_S, Q_WEIGHT_K_PER_W, k, COMPONENTS, json.dumps(info))
    save_calibration(cal, out)
    print(f"k {k} (validation accuracy by k, reference touches only: {info['validation_accuracy_by_k']}); wrote {out}")
    return info


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.material_calibrate", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=20000, help="reference touches (default 20000)")
    ap.add_argument("--out", type=Path, default=DEFAULT_CALIBRATION, help="calibration file to write")
    args = ap.parse_args(argv)
    calibrate(args.n, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
