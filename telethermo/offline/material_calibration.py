"""The slave's material classifier calibrated on simulated reference touches (issue 15): :func:`calibrate`,
run by ``python -m bench.material_calibrate``.

Reference touches are drawn like the bench's (telethermo.offline.material_touches.draws: the ten materials in
turn, force 2–10 N, object 15–35 °C, thickness 1–20 mm, noise on, the slave's default controller at rest at
the finger's natural temperature, 10 ms) but with their own seeds (material_touches.CALIBRATION), disjoint
from the bench's evaluation touches (draw seed 15, simulator seeds 1000 + i) and from its held-out set (draw
seed 2525, simulator seeds 300000 + i): a calibration whose seeds overlap either is refused, here and by the
bench. ``n_dense`` (``--dense``) more touches of ceramic and the metals at 2–6 N (their own seeds,
:data:`DENSE`), where the classes are hardest to tell apart. Per touch the slave's own touch vector
(telethermo.control.material_calib.touch_vector: the filtered signals of the 0.3 s window from the sample the
slave's detector calls contact, no truth) is kept with its material. The rig's noise covariance in that vector
(the first 2000 draws simulated with noise and without) whitens it. The networks
(telethermo.control.material_train) are trained on all of them and the classifier is written atomically; with
``check`` (``--validate``) they are first trained on four fifths and scored on the fifth left out
(interleaved; recorded in the file's info as the validation accuracy). ``cache`` (``--touches``) keeps the
simulated touches (about 15 of the 25 minutes on this machine) for training again with other settings.

On hardware the simulator's calibration does not transfer as such: the same fit on touches of the lab's own
reference samples is needed (docs/material_id.md).
"""

from __future__ import annotations

import io
import json
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from telethermo.atomic import write_bytes_atomic
from telethermo.control import material_id as mi
from telethermo.control.material_calib import save_calibration, touch_vector
from telethermo.control.material_train import TrainSettings, accuracy, build_calibration
from telethermo.sim.measurement import NoiseParams
from telethermo.offline.material_touches import (
    CALIBRATION,
    PERIOD_S,
    PRE_S,
    SIM_TO_TABLE,
    draws,
    finger_natural_C,
    refuse_overlap,
    simulate_touch,
)
from telethermo.sim.tem import load_rig_params

#: the flux's weight in the touch vector, K/W
Q_WEIGHT_K_PER_W = 3.0
#: touches simulated twice (noise on and off) for the noise covariance; its floor (material_calib.whitener)
NOISE_TOUCHES, NOISE_FLOOR = 2000, 0.01
#: the extra reference touches' (draw seed, first simulator seed), classes (ceramic and the five metals: the
#: effusivity hides behind the contact resistance, where the classes are hardest to tell apart) and
#: force range
DENSE, DENSE_CLASSES, DENSE_FORCE_N = (1616, 400_000), (4, 5, 6, 7, 8, 9), 6.0


def touch_record(params, T_probe_C: float, d: dict, noise: NoiseParams | None = None):
    """(T_sensor_C, Q_W, the sample the slave's detector calls contact) of one drawn touch (``noise`` None:
    the rig's default noise), simulated without the core's own identification (the same current)."""
    T, Q, i0, _, _ = simulate_touch(
        params,
        list(SIM_TO_TABLE)[d["class"]],
        d["thickness_m"],
        d["T_object_C"],
        d["force_N"],
        T_probe_C,
        seed=d["seed"],
        t_on_s=d["t_on_s"],
        noise=noise,
        identify=False,
    )
    return T, Q, i0


def vector_of(
    T: np.ndarray, Q: np.ndarray, i0: int, probe: mi.ProbeParams = mi.ProbeParams()
) -> np.ndarray | None:
    """The slave's touch vector of one record (None without a complete window)."""
    inp = mi.fit_input(T, Q, i0, PERIOD_S, probe) if i0 >= 0 else None
    return touch_vector(inp, Q_WEIGHT_K_PER_W) if inp is not None else None


def dense_draws(n: int, seeds: tuple[int, int]) -> list[dict]:
    """``n`` extra reference draws where the classes are hardest to tell apart: the classes of
    :data:`DENSE_CLASSES` in turn, under a contact resistance (force 2–6 N); object temperature, thickness and
    onset as :func:`telethermo.offline.material_touches.draws`."""
    rng = np.random.default_rng(seeds[0])
    out = []
    for i in range(n):
        out.append(
            {
                "class": DENSE_CLASSES[i % len(DENSE_CLASSES)],
                "force_N": float(rng.uniform(2.0, DENSE_FORCE_N)),
                "T_object_C": float(rng.uniform(15.0, 35.0)),
                "thickness_m": float(rng.uniform(1.0, 20.0)) * 1e-3,
                "t_on_s": PRE_S + float(rng.uniform(0.0, PERIOD_S)),
                "seed": seeds[1] + i,
            }
        )
    return out


def _vectors(chunk: list[dict]) -> list[tuple[np.ndarray | None, int]]:
    """(touch vector or None, class) of each draw of ``chunk`` (one worker's share)."""
    params = load_rig_params()
    T_probe = finger_natural_C(params)
    return [(vector_of(*touch_record(params, T_probe, d)), d["class"]) for d in chunk]


def reference_set(
    n: int, seeds: tuple[int, int], dense: bool = False, jobs: int = 1, chunk: int = 2000
) -> tuple[np.ndarray, np.ndarray]:
    """(touch vectors, class indices) of ``n`` reference touches (touches without a window left out);
    ``dense``: drawn by :func:`dense_draws` instead of the bench's distribution; simulated in ``jobs``
    processes (the same touches in the same order whatever ``jobs``)."""
    refuse_overlap(n, seeds)
    todo = dense_draws(n, seeds) if dense else draws(n, seeds)
    parts = [todo[i : i + chunk] for i in range(0, len(todo), chunk)]
    V, y = [], []
    with ProcessPoolExecutor(max_workers=max(jobs, 1)) as pool:
        for i, done in enumerate(pool.map(_vectors, parts)):
            for v, c in done:
                if v is not None:
                    V.append(v)
                    y.append(c)
            print(f"  {min((i + 1) * chunk, n)}/{n} reference touches", flush=True)
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


def validate(
    V: np.ndarray, y: np.ndarray, classes: list[str], noise_cov: np.ndarray, settings: TrainSettings
) -> float:
    """Accuracy on every fifth reference touch of networks trained on the other four fifths (interleaved: the
    dense references come last, a final fifth would be only those)."""
    val = np.arange(len(y)) % 5 == 4
    cal = build_calibration(
        V[~val], y[~val], classes, PERIOD_S, Q_WEIGHT_K_PER_W, noise_cov, NOISE_FLOOR, settings
    )
    return accuracy(cal, V[val], y[val])


def touches(
    n: int, n_dense: int, jobs: int, cache: Path | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(touch vectors, class indices, noise covariance) of the reference touches: read from ``cache`` when it
    holds the same draws, else simulated (and written there atomically, so that training again with other
    settings does not simulate again)."""
    key = np.array([n, n_dense, *CALIBRATION, *DENSE, NOISE_TOUCHES])
    if cache is not None and cache.exists():
        with np.load(cache, allow_pickle=False) as c:
            if "key" in c.files and np.array_equal(c["key"], key):
                print(f"reference touches read from {cache}")
                return c["V"], c["y"], c["S"]
            print(f"{cache} holds other draws: simulated again")
    V, y = reference_set(n, CALIBRATION, jobs=jobs)
    if n_dense:
        Vd, yd = reference_set(n_dense, DENSE, dense=True, jobs=jobs)
        V, y = np.concatenate([V, Vd]), np.concatenate([y, yd])
    S = noise_covariance(min(NOISE_TOUCHES, n), CALIBRATION)
    if cache is not None:
        buf = io.BytesIO()
        np.savez(buf, key=key, V=V, y=y, S=S)
        write_bytes_atomic(cache, buf.getvalue())
    return V, y, S


def calibrate(
    n: int,
    out: Path,
    n_dense: int = 0,
    jobs: int = 1,
    settings: TrainSettings = TrainSettings(),
    cache: Path | None = None,
    check: bool = False,
) -> dict:
    """Simulate ``n`` reference touches (and ``n_dense`` extra ones, :func:`dense_draws`) in ``jobs``
    processes (or read them from ``cache``), with ``check`` validate on a fifth left out, train on all, write
    ``out``; returns what was done."""
    classes = [SIM_TO_TABLE[m] for m in SIM_TO_TABLE]
    V, y, S = touches(n, n_dense, jobs, cache)
    score = validate(V, y, classes, S, settings) if check else None
    info = {
        "reference_touches": int(n),
        "draw_seed": CALIBRATION[0],
        "sim_seed_first": CALIBRATION[1],
        "dense": {
            "touches": int(n_dense),
            "draw_seed": DENSE[0],
            "sim_seed_first": DENSE[1],
            "classes": [classes[c] for c in DENSE_CLASSES],
            "force_N": [2.0, DENSE_FORCE_N],
        },
        "references_kept": int(len(y)),
        "period_s": PERIOD_S,
        "source": "simulated (python -m bench.material_calibrate): force 2-10 N, object "
        "15-35 C, thickness 1-20 mm, noise on, slave default controller, probe at the finger's natural "
        "temperature",
        "onset": "the slave's contact detector (as telethermo.control.material_stream)",
        "whitening": {"noise_touches": min(NOISE_TOUCHES, n), "floor": NOISE_FLOOR},
        "training": dict(vars(settings)),
        "validation_accuracy": None if score is None else round(score, 4),
    }
    cal = build_calibration(
        V, y, classes, PERIOD_S, Q_WEIGHT_K_PER_W, S, NOISE_FLOOR, settings, json.dumps(info)
    )
    save_calibration(cal, out)
    if score is not None:
        print(f"validation accuracy (four fifths of the references trained, the fifth left out) {score:.4f}")
    print(f"wrote {out}")
    return info
