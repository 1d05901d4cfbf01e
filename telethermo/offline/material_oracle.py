"""The physical ceiling of material identification on the bench's touches: an oracle that knows the simulator.

Per touch (the draws of telethermo/offline/material_touches.py, which bench/material_id_bench.py uses), the
probe is simulated WITHOUT noise for each of the ten candidate materials under the touch's own force, object
temperature and thickness, and the true (unfiltered) sensor signals are recorded: T_sensor (thermocouple) and
Q (flux) over the estimator's window, the first 0.3 s after the touch. The rig's measurement is those signals
plus white noise (sim.measurement: σ_T, σ_Q and the ADC's step², /12) then the rig's low-pass: the filter is
invertible given the whole record, so the unfiltered samples plus white noise are a sufficient statistic, and
every sample before the touch is the same for every candidate. The classifier that knows the simulator exactly
then sees whitened vectors z_j (T/σ_T', Q/σ_Q').

Two oracles, both with the rig's own noise drawn ``DRAWS`` times per touch (Monte-Carlo accuracy):

- ``known_nuisance``: it also knows the touch's contact resistance (force), object temperature and
  thickness: maximum likelihood over the ten traces. With equal class priors (the bench cycles through the
  materials) this is Bayes-optimal with more knowledge than any estimator has: a strict upper bound.
- ``unknown_nuisance`` (the headline ``material_id_accuracy_bound``): the object's initial temperature, the
  contact resistance and the thickness are unknown; for each candidate they are profiled out (generalised
  likelihood ratio) in the linearisation of that candidate's trace about the touch's values (finite
  differences: +1 °C, the force towards a larger contact resistance, thickness × 1.15). Local: a wrong
  material far away in thickness or force that happens to fit is not found, so this is still optimistic.

Not in either: the noise's feedback through the controller (it moves the probe by the filtered noise), the
model errors a real estimator makes. A touch is ``unidentifiable`` when the unknown-nuisance oracle is right
in fewer than half of its draws.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from telethermo.sim.measurement import NoiseParams
from telethermo.sim.plant import Body, GridSettings
from telethermo.sim.rig import SimRig
from telethermo.sim.touch import BodySpec, Schedule, Touch
from telethermo.control.core import init_state, step
from telethermo.control.params import default_params
from telethermo.control.types import PeerValues, Role

DRAWS = 400
WINDOW_S = 0.3
DT_PERTURB_C, THICKNESS_FACTOR, FORCE_PERFECT_N = 1.0, 1.15, 6.0


def true_traces(
    params,
    mat: str,
    thickness_m: float,
    T_object_C: float,
    force_N: float,
    T_probe_C: float,
    t_on_s: float,
    period_s: float,
    ambient_C: float,
    window_s: float = WINDOW_S,
    core_params=None,
) -> np.ndarray:
    """[T_sensor_true (°C) ..., Q_true (W) ...] over the ``window_s`` (s) after the first contact sample,
    noise off; the slave's core runs ``core_params`` (None: its defaults, before ``telethermo identify``)."""
    grid = GridSettings(t_min_s=period_s)
    spec = BodySpec("object", material=mat, thickness_m=thickness_m, T0_C=T_object_C)
    body = Body(spec, params.area_m2, ambient_C, params.h_air_W_m2K, grid)
    rig = SimRig(
        params,
        {"object": body},
        Schedule([Touch(t_on_s, t_on_s + 10.0, "object", force_N)]),
        ambient_C=ambient_C,
        period_s=period_s,
        noise=NoiseParams(enabled=False),
        seed=0,
        grid=grid,
        start=T_probe_C,
    )
    cp = replace(core_params or default_params(Role.SLAVE, period_s=period_s), material_id=None)
    s = rig.read()
    st = init_state(cp, None, s)
    peer = PeerValues(estimate_C=T_probe_C, flux_W=0.0)
    n_win = int(round(window_s / period_s))
    T, Q = [], []
    while len(T) < n_win:
        s = rig.read()
        if s.contact:
            tr = rig.truth()
            T.append(tr.T_sensor_true_C)
            Q.append(tr.Q_true_W)
        r = step(s, peer, cp, st)
        st = r.state
        rig.apply_current(r.current_A)
        rig.advance(period_s)
    return np.array(T + Q)


def noise_scale(noise: NoiseParams, n_win: int) -> np.ndarray:
    """Per-element σ of the unfiltered measurement: noise and the ADC step (uniform: step²/12)."""
    sT = math.sqrt(noise.T_sigma_C**2 + noise.T_lsb_C**2 / 12.0)
    sQ = math.sqrt(noise.Q_sigma_W**2 + noise.Q_lsb_W**2 / 12.0)
    return np.concatenate([np.full(n_win, sT), np.full(n_win, sQ)])


def touch_candidates(
    params,
    sims: list[str],
    touch: dict,
    T_probe_C: float,
    period_s: float,
    ambient_C: float,
    sigma: np.ndarray,
    window_s: float = WINDOW_S,
    core_params=None,
) -> tuple[np.ndarray, np.ndarray]:
    """Whitened traces z (k, 2n) of each candidate at the touch's nuisance values and their nuisance
    sensitivities G (k, 2n, 3): object temperature, contact resistance (via force), thickness; over
    ``window_s`` (s, ``sigma`` of that many samples), the slave's core running ``core_params``."""
    f, T_o, d, t_on = touch["force_N"], touch["T_object_C"], touch["thickness_m"], touch["t_on_s"]
    f_pert = FORCE_PERFECT_N - 1.0 if f >= FORCE_PERFECT_N else 0.9 * f
    z, G = [], []
    for mat in sims:

        def tr(mm=mat, dd=d, TT=T_o, ff=f):
            out = true_traces(
                params, mm, dd, TT, ff, T_probe_C, t_on, period_s, ambient_C, window_s, core_params
            )
            return out / sigma

        base = tr()
        z.append(base)
        G.append(
            np.column_stack(
                [tr(TT=T_o + DT_PERTURB_C) - base, tr(ff=f_pert) - base, tr(dd=d * THICKNESS_FACTOR) - base]
            )
        )
    return np.array(z), np.array(G)


def residual_projector(G: np.ndarray, min_norm: float = 1e-3) -> np.ndarray:
    """I − P onto the span of G's columns (columns whose whitened norm is below ``min_norm``, i.e. changes far
    below the noise, are dropped: they carry no nuisance freedom, only round-off)."""
    cols = G[:, np.linalg.norm(G, axis=0) > min_norm]
    n = G.shape[0]
    if cols.shape[1] == 0:
        return np.eye(n)
    q, _ = np.linalg.qr(cols)
    return np.eye(n) - q @ q.T


def oracle_correct(
    z: np.ndarray, G: np.ndarray, truth: int, rng: np.random.Generator, draws: int = DRAWS
) -> tuple[float, float]:
    """(fraction of draws the known-nuisance ML oracle is right, the same for the unknown-nuisance GLRT)."""
    known, prof = oracle_answers(z, G, truth, rng, draws)
    return float(np.mean(known == truth)), float(np.mean(prof == truth))


def oracle_answers(
    z: np.ndarray, G: np.ndarray, truth: int, rng: np.random.Generator, draws: int = DRAWS
) -> tuple[np.ndarray, np.ndarray]:
    """The class each oracle names in each of ``draws`` noise draws of candidate ``truth``: (known-nuisance
    ML, unknown-nuisance GLRT), each an int array of ``draws`` (its histogram: the oracle's confusion row)."""
    k, m = z.shape
    W = rng.standard_normal((draws, m))
    obs = z[truth] + W  # (draws, m)
    d_known = np.stack([np.sum((obs - z[j]) ** 2, axis=1) for j in range(k)], axis=1)
    return np.argmin(d_known, axis=1), np.argmin(profiled_distances(z, G, obs), axis=1)


def profiled_distances(z: np.ndarray, G: np.ndarray, obs: np.ndarray) -> np.ndarray:
    """(draws, k): each observation's squared residual to each candidate's trace z[j], its nuisances
    profiled out in the linearisation G[j] (the unknown-nuisance GLRT's statistic)."""
    return np.stack(
        [np.sum(((obs - z[j]) @ residual_projector(G[j])) ** 2, axis=1) for j in range(len(z))], axis=1
    )


def bound_figures(
    params,
    sims: list[str],
    touches: list[dict],
    T_probe_C: float,
    period_s: float,
    ambient_C: float,
    estimator_right: list[bool],
) -> dict[str, Any]:
    """The oracles' accuracy over the bench's touches, the unidentifiable fraction, by |ΔT| bin, and the
    estimator's accuracy over the touches the unknown-nuisance oracle identifies (≥ 0.95 of its draws)."""
    noise = NoiseParams()
    n_win = int(round(WINDOW_S / period_s))
    sigma = noise_scale(noise, n_win)
    rng = np.random.default_rng(1515)
    known, prof = [], []
    for t in touches:
        z, G = touch_candidates(params, sims, t, T_probe_C, period_s, ambient_C, sigma)
        a, b = oracle_correct(z, G, t["class"], rng)
        known.append(a)
        prof.append(b)
    prof_a, known_a = np.array(prof), np.array(known)
    dT = np.array([abs(t["T_object_C"] - T_probe_C) for t in touches])
    right = np.array(estimator_right, bool)
    ident = prof_a >= 0.95
    bins = [(0.0, 1.0), (1.0, 2.0), (2.0, 5.0), (5.0, 10.0), (10.0, 25.0)]
    by_dT = []
    for lo, hi in bins:
        m = (dT >= lo) & (dT < hi)
        if m.any():
            by_dT.append(
                {
                    "abs_dT_C": [lo, hi],
                    "n": int(m.sum()),
                    "bound": round(float(prof_a[m].mean()), 3),
                    "bound_known_nuisance": round(float(known_a[m].mean()), 3),
                    "estimator": round(float(right[m].mean()), 3),
                }
            )
    per_class = {}
    for j, mat in enumerate(sims):
        m = np.array([t["class"] == j for t in touches])
        per_class[mat] = {
            "bound": round(float(prof_a[m].mean()), 3),
            "estimator": round(float(right[m].mean()), 3),
        }
    return {
        "material_id_accuracy_bound": float(prof_a.mean()),
        "material_id_accuracy_bound_known_nuisance": float(known_a.mean()),
        "material_id_accuracy_bound_method": (
            "Monte-Carlo accuracy of an oracle that knows the simulator: per touch, noiseless true T_sensor "
            f"and Q over the {WINDOW_S} s window for each of the 10 materials, the rig's noise (sigma and "
            f"ADC step, white before its invertible filter) drawn {DRAWS} times; headline: object "
            "temperature, contact resistance and thickness unknown, profiled out per candidate in the "
            "linearisation about the touch's values (GLRT; local, so still optimistic); _known_nuisance: ML "
            "knowing them (strict upper bound)"
        ),
        "material_id_unidentifiable_fraction": float(np.mean(prof_a < 0.5)),
        "material_id_identifiable_n": int(ident.sum()),
        "material_id_accuracy_identifiable": float(right[ident].mean()) if ident.any() else math.nan,
        "material_id_identifiable_rule": (
            "touches the unknown-nuisance oracle classifies right in >= 95 % of draws"
        ),
        "material_id_bound_by_dT": by_dT,
        "material_id_bound_by_material": per_class,
    }
