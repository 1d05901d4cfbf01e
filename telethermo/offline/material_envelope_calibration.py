"""The slave's envelope classifiers (issue 23), trained on reference touches across the operating envelope:
:func:`calibrate`, run by ``python -m bench.material_envelope_calibrate``.

Three classifiers: the early answer's over 0.42 s (every sample), the refined answer's over 1.2 s (every 4th
sample), and the one the refined answer pools with over 0.3 s (every sample; the pool's weights fitted on
development touches, :func:`record_pool`), each a network over material_calib.envelope_vector (the touch's
shape, divided by its size and by the direction of its heat flow, then that size, the direction and the
probe's pre-contact state), trained on :mod:`telethermo.offline.material_envelope_refs`' touches
(192 000, the shipped probe and a family of other modules after ``identify``). The slave uses them outside
the in-box classifier's box (telethermo.control.material_stream). Features and network size were chosen on
a development set of other seeds (material_envelope_refs.ENV_DEVELOPMENT; docs/material_id.md).

A lab with another probe re-runs this on its own rig's model (the family is drawn around the shipped module)
or on recorded touches of reference samples: any (T_sensor, Q) records whose contact sample is known give the
same vectors (:func:`vectors`).
"""

from __future__ import annotations

import json
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from scipy.optimize import minimize

from telethermo.control import material_id as mi
from telethermo.control.material_calib import (
    ENVELOPE_EARLY,
    ENVELOPE_LATE,
    ENVELOPE_POOL,
    Calibration,
    envelope_vector,
    inputs,
    load_calibration,
    posterior,
    pooled,
    save_calibration,
    with_ranges,
)
from telethermo.control.material_train import TrainSettings, train_network
from telethermo.offline.material_envelope_refs import (
    ENV_DEVELOPMENT,
    ENV_DEVELOPMENT_N,
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


class Window(NamedTuple):
    """What an envelope classifier sees: its window (s) and every ``sub``-th sample of it."""

    window_s: float
    sub: int


#: the early answer's classifier, the one the refined answer pools with and the refined answer's (the early
#: answer's 0.42 s: as long as the answer 0.49 s after the contact allows with three units of the physics fit
#: a cycle (material_stream.UNITS_PER_CYCLE); the development set's choice over 0.34 s and the 0.3 s the pool
#: keeps, docs/material_id.md)
EARLY, POOL, LATE = Window(0.42, 1), Window(0.3, 1), Window(1.2, 4)
#: where :func:`calibrate` writes them
OUT = (ENVELOPE_EARLY, ENVELOPE_POOL, ENVELOPE_LATE)
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
    V: np.ndarray,
    y: np.ndarray,
    window_s: float,
    sub: int,
    settings: TrainSettings,
    info: str,
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
    out: tuple[Path, Path, Path] = OUT,
    settings: TrainSettings = SETTINGS,
    dev: str | Path | None = None,
) -> tuple[Calibration, Calibration, Calibration]:
    """Simulate ``n`` reference touches (or read them from ``refs`` when it exists; written there when it
    does not), train the three classifiers (:data:`EARLY`, :data:`POOL`, :data:`LATE`), fit the refined
    answer's pool on the development touches (:func:`record_pool`, ``dev`` its cache) and write them to
    ``out`` atomically."""
    data = _touches(refs, n, ENV_REFERENCES, jobs, _progress)
    y = data["class"].astype(int)
    made = []
    for win in (EARLY, POOL, LATE):
        V, ok = vectors(data["T"], data["Q"], KEEP_PRE, *win)
        info = json.dumps(
            {
                "what": "envelope classifier (telethermo.offline.material_envelope_calibration)",
                "draw_seed": ENV_REFERENCES[0],
                "sim_seed_first": ENV_REFERENCES[1],
                "reference_touches": int(n),
                "used": int(ok.sum()),
                "tem_family": {"n": N_TEMS, "seed": TEM_FAMILY_SEED},
                "window_s": win.window_s,
                "sub": win.sub,
                "settings": asdict(settings),
            }
        )
        made.append(build(V, y[ok], win.window_s, win.sub, settings, info))
    dev_data = _touches(dev, ENV_DEVELOPMENT_N, ENV_DEVELOPMENT, jobs)
    early, partner, late = made[0], made[1], replace(made[2], pool=fit_pool(made[1], made[2], dev_data))
    for cal, dest in zip((early, partner, late), out):
        save_calibration(cal, dest)
    return early, partner, late


def _touches(
    cache: str | Path | None, n: int, seeds: tuple[int, int], jobs: int, progress: Any = None
) -> dict[str, np.ndarray]:
    """``n`` simulated touches of ``seeds`` (material_envelope_refs.reference_set), read from ``cache`` when
    it exists, kept there when it does not."""
    path = Path(cache) if cache is not None else None
    if path is not None and path.exists():
        with np.load(path) as f:
            return {k: f[k] for k in f.files}
    data = reference_set(n, seeds, jobs=jobs, progress=progress)
    if path is not None:
        np.savez(path, **data)
    return data


def record_ranges(refs: str | Path, paths: tuple[Path, Path, Path] = OUT) -> tuple[Calibration, ...]:
    """Record the range of the references' network inputs (material_calib.with_ranges) in the classifiers at
    ``paths`` (as :data:`OUT`) from the reference touches they were trained on (``refs``, as
    :func:`calibrate` keeps them), the networks unchanged; written atomically."""
    with np.load(Path(refs)) as f:
        T, Q = f["T"], f["Q"]
    made = []
    for win, path in zip((EARLY, POOL, LATE), paths):
        cal = load_calibration(path)
        V, _ = vectors(T, Q, KEEP_PRE, win.window_s, cal.sub)
        cal = with_ranges(cal, inputs(cal.center, cal.whiten, cal.scale, V))
        save_calibration(cal, path)
        made.append(cal)
    return tuple(made)


def fit_pool(early: Calibration, late: Calibration, data: dict[str, np.ndarray]) -> tuple[float, float]:
    """The refined answer's pool weights (material_calib.pooled): the (early, refined) weights, both ≥ 0, that
    maximise the likelihood of the true classes of touches ``data`` (as :func:`calibrate` keeps them; the
    development set's, never references the networks were trained on)."""
    y = data["class"].astype(int)
    Ve, ok_e = vectors(data["T"], data["Q"], KEEP_PRE, early.n_win * PERIOD_S, early.sub)
    Vl, ok_l = vectors(data["T"], data["Q"], KEEP_PRE, late.n_win * PERIOD_S, late.sub)
    both = ok_e & ok_l
    return pool_weights(scores(early, Ve[both[ok_e]]), scores(late, Vl[both[ok_l]]), y[both])


def pool_weights(P_early: np.ndarray, P_late: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """The weights (each in [0, 4]) of material_calib.pooled that maximise the likelihood of classes ``y``
    given the two classifiers' posteriors (touches × classes), by Nelder–Mead from (0.5, 1)."""
    y = np.asarray(y, int)

    def nll(w: np.ndarray) -> float:
        p = pooled(P_early, P_late, (float(w[0]), float(w[1])))
        return -float(np.sum(np.log(np.maximum(p[np.arange(y.size), y], 1e-30))))

    bounds = [(0.0, 4.0), (0.0, 4.0)]
    res = minimize(nll, np.array([0.5, 1.0]), method="Nelder-Mead", bounds=bounds, options={"xatol": 1e-4})
    return round(float(res.x[0]), 4), round(float(res.x[1]), 4)


def record_pool(
    dev: str | Path | None = None,
    jobs: int = 1,
    paths: tuple[Path, Path] = (ENVELOPE_POOL, ENVELOPE_LATE),
) -> tuple[float, float]:
    """Fit the refined answer's pool (:func:`fit_pool`) on the development touches (material_envelope_refs.
    ENV_DEVELOPMENT; read from ``dev`` when it exists, kept there when it does not) and record it in the
    refined classifier at ``paths[1]`` (the networks unchanged; written atomically)."""
    data = _touches(dev, ENV_DEVELOPMENT_N, ENV_DEVELOPMENT, jobs)
    early, late = load_calibration(paths[0]), load_calibration(paths[1])
    w = fit_pool(early, late, data)
    save_calibration(replace(late, pool=w), paths[1])
    return w


def _progress(k: int, n: int) -> None:
    print(f"  {k}/{n} reference touches", flush=True)
