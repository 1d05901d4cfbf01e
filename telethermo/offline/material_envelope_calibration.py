"""The slave's envelope classifiers (issue 23), trained on reference touches across the operating envelope:
:func:`calibrate`, run by ``python -m bench.material_envelope_calibrate``.

Two classifiers, one per answer: the early one over the 0.3 s window (every sample), the refined one over
1.2 s (every 4th sample), each a network over telethermo.control.material_calib.envelope_vector (the touch's
shape, divided by its size and by the direction of its heat flow, then that size, the direction and the
probe's pre-contact state), trained on :mod:`telethermo.offline.material_envelope_refs`' touches (192 000, the
shipped probe and a family of other modules after ``identify``). The slave uses them outside the in-box
classifier's box (telethermo.control.material_stream). Features and network size were chosen on a
development set of other seeds (material_envelope_refs.ENV_DEVELOPMENT; docs/material_id.md).

A lab with another probe re-runs this on its own rig's model (the family is drawn around the shipped module)
or on recorded touches of reference samples: any (T_sensor, Q) records whose contact sample is known give the
same vectors (:func:`vectors`).
"""

from __future__ import annotations

import json
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np

from telethermo.control import material_id as mi
from telethermo.control.material_calib import (
    ENVELOPE_EARLY,
    ENVELOPE_LATE,
    Calibration,
    envelope_vector,
    inputs,
    load_calibration,
    posterior,
    save_calibration,
    with_ranges,
)
from telethermo.control.material_train import TrainSettings, train_network
from telethermo.offline.material_envelope_refs import (
    ENV_REFERENCES,
    ENV_REFERENCES_N,
    KEEP_PRE,
    N_TEMS,
    TEM_FAMILY_SEED,
    reference_set,
)
from telethermo.offline.material_touches import PERIOD_S, SIM_TO_TABLE

#: the flux's weight in the vectors, K/W (as the in-box classifier's)
Q_WEIGHT_K_PER_W = 3.0
#: (window s, every n-th sample) of the early and the refined answer's classifier
EARLY, LATE = (0.3, 1), (1.2, 4)
#: how the networks are trained (the development set's choice: 3 × 256, 60 epochs; docs/material_id.md)
SETTINGS = TrainSettings(hidden=256, layers=3, epochs=60, batch=256, warmup=50, weight_decay=1e-4)


def vectors(
    T: np.ndarray, Q: np.ndarray, i0: int, window_s: float, sub: int
) -> tuple[np.ndarray, np.ndarray]:
    """(envelope vectors, which records have one) of records ``T``, ``Q`` (records × samples; the contact
    sample at index ``i0`` of each) over ``window_s`` (every ``sub``-th sample)."""
    probe = replace(mi.ProbeParams(), window_s=window_s)
    out, ok = [], np.zeros(len(T), bool)
    for k in range(len(T)):
        inp = mi.fit_input(T[k], Q[k], i0, PERIOD_S, probe)
        if inp is not None:
            out.append(envelope_vector(inp, Q_WEIGHT_K_PER_W, sub))
            ok[k] = True
    return np.array(out), ok


def build(
    V: np.ndarray, y: np.ndarray, window_s: float, sub: int, settings: TrainSettings, info: str
) -> Calibration:
    """An envelope classifier from vectors ``V`` and class indices ``y`` (into SIM_TO_TABLE's order): each
    feature standardised over the references, one network."""
    center = V.mean(axis=0)
    whiten = np.diag(1.0 / (V.std(axis=0) + 1e-6))
    X = inputs(center, whiten, 1.0, V)
    net = train_network(X, y, len(SIM_TO_TABLE), settings, settings.seed)
    cal = Calibration(
        classes=tuple(SIM_TO_TABLE.values()),
        dt_s=PERIOD_S,
        n_win=int(round(window_s / PERIOD_S)),
        q_weight_K_per_W=Q_WEIGHT_K_PER_W,
        center=center,
        whiten=whiten,
        scale=1.0,
        nets=(net,),
        info=info,
        features="envelope",
        sub=sub,
    )
    return with_ranges(cal, X)


def scores(cal: Calibration, V: np.ndarray) -> np.ndarray:
    """The classifier's posterior (touches × classes) of vectors ``V`` (a batch, for development)."""
    return posterior(cal, inputs(cal.center, cal.whiten, cal.scale, V))


def calibrate(
    n: int = ENV_REFERENCES_N,
    jobs: int = 1,
    refs: str | Path | None = None,
    out: tuple[Path, Path] = (ENVELOPE_EARLY, ENVELOPE_LATE),
    settings: TrainSettings = SETTINGS,
) -> tuple[Calibration, Calibration]:
    """Simulate ``n`` reference touches (or read them from ``refs`` when it exists; written there when it
    does not), train the early and the refined answer's classifiers and write them to ``out`` atomically."""
    path = Path(refs) if refs is not None else None
    if path is not None and path.exists():
        with np.load(path) as f:
            data = {k: f[k] for k in f.files}
    else:
        data = reference_set(n, ENV_REFERENCES, jobs=jobs, progress=_progress)
        if path is not None:
            np.savez(path, **data)
    y = data["class"].astype(int)
    made = []
    for (window_s, sub), dest in zip((EARLY, LATE), out):
        V, ok = vectors(data["T"], data["Q"], KEEP_PRE, window_s, sub)
        info = json.dumps(
            {
                "what": "envelope classifier (telethermo.offline.material_envelope_calibration)",
                "draw_seed": ENV_REFERENCES[0],
                "sim_seed_first": ENV_REFERENCES[1],
                "reference_touches": int(n),
                "used": int(ok.sum()),
                "tem_family": {"n": N_TEMS, "seed": TEM_FAMILY_SEED},
                "window_s": window_s,
                "sub": sub,
                "settings": asdict(settings),
            }
        )
        cal = build(V, y[ok], window_s, sub, settings, info)
        save_calibration(cal, dest)
        made.append(cal)
    return made[0], made[1]


def record_ranges(
    refs: str | Path, paths: tuple[Path, Path] = (ENVELOPE_EARLY, ENVELOPE_LATE)
) -> tuple[Calibration, Calibration]:
    """Record the range of the references' network inputs (material_calib.with_ranges) in the classifiers at
    ``paths`` (early, refined) from the reference touches they were trained on (``refs``, as
    :func:`calibrate` keeps them), the networks unchanged; written atomically."""
    with np.load(Path(refs)) as f:
        T, Q = f["T"], f["Q"]
    made = []
    for (window_s, sub), path in zip((EARLY, LATE), paths):
        cal = load_calibration(path)
        V, _ = vectors(T, Q, KEEP_PRE, window_s, sub)
        cal = with_ranges(cal, inputs(cal.center, cal.whiten, cal.scale, V))
        save_calibration(cal, path)
        made.append(cal)
    return made[0], made[1]


def _progress(k: int, n: int) -> None:
    print(f"  {k}/{n} reference touches", flush=True)
