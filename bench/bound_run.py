"""The optimal-current bound per touch of a scene (telethermo.offline.bound), with its replay check through
``sim.rig.SimRig`` and, on request, the foreknowledge front and the clamped bound (skin kept inside the
clamps). Used by bench.transparency_bench and the envelope benches."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from telethermo import sim
from telethermo.offline.bound import (
    BatchedPlant,
    Window,
    causal_bound,
    clamp_excess,
    foresight_bound,
    matched_start,
    replay,
    window_errors,
)
from telethermo.offline.transparency import DSKIN_AT_S

PRE_N, EARLY_N = 50, 100  # samples at 10 ms: 0.5 s before, 1 s after each touch


def run_bound(
    sc,
    t_ref,
    skin_ref,
    cells,
    *,
    maxiter: int,
    front_weights: tuple,
    front_touches: int,
    q_ref=None,
    clamp_C: tuple[float, float] | None = None,
    starts: list[np.ndarray] | None = None,
    restarts_A: tuple[float, ...] = (),
) -> dict[str, Any]:
    """The causal bound per touch, its replay check, and the foreknowledge front. With ``q_ref`` (the direct
    touch's heat into the finger, W, per period: :func:`reference_track`) each touch also carries the direct
    touch's cue over the same samples as the bound's (``direct_cue_J``). With ``clamp_C`` (lo, hi), °C, the
    clamped bound (telethermo.offline.bound), and each touch carries the skin's largest excursion beyond it
    (``clamp_excess_C``). ``starts``: the master rig's state at each window's start, in the order of the
    touches, instead of the matched (direct-touch) finger. ``restarts_A``: further starting currents of the
    search (telethermo.offline.bound.causal_bound)."""
    mk = lambda: sim.build_rig(sc, "master", noise=False)  # noqa: E731
    rig = mk()
    plant = BatchedPlant(rig, sc.period_s)
    per, traj, front = [], [], []
    x0s = starts
    if x0s is None:  # the direct-touch finger (clipped to the clamps: no display inside them leaves it there)
        k0s = [int(round(c.start_s / sc.period_s)) - PRE_N for c in sc.slave_contacts]
        fingers = [cells[k] if clamp_C is None else np.clip(cells[k], *clamp_C) for k in k0s]
        x0s = [matched_start(rig, f) for f in fingers]
    for i, c in enumerate(sc.slave_contacts):
        k0 = int(round(c.start_s / sc.period_s)) - PRE_N
        n_early = min(EARLY_N, int(round((c.end_s - c.start_s) / sc.period_s)))
        w = Window(
            t0_s=k0 * sc.period_s,
            n_pre=PRE_N,
            n_early=n_early,
            x0=x0s[i],
            ref_C=skin_ref[k0 : k0 + PRE_N + n_early],
        )
        t0 = time.perf_counter()
        u = causal_bound(plant, w, maxiter=maxiter, clamp_C=clamp_C, restarts_A=restarts_A)
        heat: list = []
        skin = plant.run(w.x0, u[:-1, None], heat)[:, 0]
        excess = {} if clamp_C is None else {"clamp_excess_C": float(np.max(clamp_excess(skin, clamp_C)))}
        q = np.array(heat)[:, 0]
        cue_J = -float(np.sum(q[PRE_N : PRE_N + n_early]) * sc.period_s)
        k1 = k0 + PRE_N  # the direct touch's cue over the bound's samples (with q_ref)
        direct = (
            {} if q_ref is None else {"direct_cue_J": -float(np.sum(q_ref[k1 : k1 + n_early]) * sc.period_s)}
        )
        replayed = replay(mk, w, u, sc.period_s)
        err = window_errors(skin, w)
        per.append(
            {
                "object": c.body,
                **err,
                **excess,
                "cue_J": cue_J,
                **direct,
                "replay_max_diff_C": float(np.max(np.abs(skin - replayed))),
                "optimise_s": time.perf_counter() - t0,
                "dskin_at": {
                    f"{d:g}s": float(
                        skin[min(PRE_N + int(round(d / sc.period_s)), len(skin) - 1)] - skin[PRE_N - 1]
                    )
                    for d in DSKIN_AT_S
                    if d <= 1.0
                },
            }
        )
        traj.append({"t_s": (k0 + np.arange(len(skin))) * sc.period_s, "skin_C": skin, "current_A": u})
        if i < front_touches:
            for wp in front_weights:
                uf = foresight_bound(plant, w, wp, maxiter=maxiter)
                ef = window_errors(plant.run(w.x0, uf[:-1, None])[:, 0], w)
                front.append({"object": c.body, "touch": i, "weight_pre": wp, **ef})
    return {"per_touch": per, "trajectories": traj, "front": front}
