"""The physical bound of transparency: optimal display currents on the exact simulated plant (issue 11).

For one touch of the probe at t_on, the display (the master rig with the operator's finger) starts at
t_on − 0.5 s with the finger **matched** to the direct-touch finger (the finger's cells are the reference
finger's cells at that instant; the pad stack is at the finger's surface temperature, the heat sink at its
steady state) and the current, piecewise constant over each 10 ms period, |I| ≤ 0.8·I_max (the envelope's
current limit), is chosen to minimise the mean |skin − direct-touch skin|:

- **causal** (no foreknowledge of the touch): the currents before t_on minimise the error before t_on only
  (they cannot know a touch comes); then the currents from t_on minimise the early error (0–1 s);
- **foreknowledge** (the trade-off front): all currents together minimise
  ``w·pre + (1 − w)·early`` for a weight w.

The plant is integrated exactly as ``sim.rig.SimRig`` does (same step matrices, same implicit solve of the
plate temperatures), batched over columns so that a forward-difference gradient over every current costs
one batched run; :func:`replay` re-runs a current sequence through ``SimRig`` itself (the bound is checked
against it to 1e-9 °C; the plate solve is sim.rig.plate_heats itself, on arrays). L-BFGS-B (scipy) does the
search; the smooth |e| ≈ √(e² + ε²), ε = 0.01 °C.

With ``clamp_C=(lo, hi)`` the skin must also stay inside [lo, hi] °C at every sample the currents reach (the
*clamped* bound: what a display that keeps the skin envelope of DESIGN.md §6 could at best do): a penalty
:data:`CLAMP_WEIGHT`·(distance beyond the clamp)² per sample is added to the error; the skin's largest
excursion beyond the clamp is small (checked by the caller: :func:`clamp_excess`), not exactly 0. The error
of the penalised optimum is still a lower bound on any display inside the clamps (such a display pays no
penalty, so its error is at least the optimum's objective), as long as the optimiser finds the optimum.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from telethermo.sim.rig import SimRig, plate_heats

EPS_C = 0.01
FD_STEP_A = 1e-5
#: the clamped bound's penalty per sample, per °C² beyond the clamp: 0.1 °C beyond costs as much as 1 °C of
#: error on one sample (1e4 stalls L-BFGS-B's line search at its first step on a hot object: a full-current
#: step overshoots the clamp by degrees)
CLAMP_WEIGHT = 1e2


@dataclass
class Window:
    """One touch's optimisation window: the start state and the reference skin at each sample."""

    t0_s: float  # window start (t_on − pre_s), s
    n_pre: int  # samples before the touch
    n_early: int  # samples from the touch on
    x0: np.ndarray  # the master rig's augmented state at t0 (finger attached)
    ref_C: np.ndarray  # direct-touch skin at samples 0 .. n_pre + n_early − 1, °C


class BatchedPlant:
    """The master rig's plant (finger attached), integrated for many current sequences at once."""

    def __init__(self, rig: SimRig, period_s: float) -> None:
        self.rig = rig
        cfg = rig.cfg
        if cfg.body is None:
            raise ValueError("BatchedPlant: the finger must be on the display")
        self.Phi, self.c, self.Bcat, self.rows = cfg.step(period_s)
        self.n = cfg.n
        self.surf_f = np.append(cfg.surf_f, 0.0)
        self.surf_f0 = cfg.surf_f0
        self.q_f = np.append(cfg.body_q_f, 0.0)  # heat into the finger across the contact, W
        self.q_f0 = cfg.body_q_f0
        self.alpha, self.R, self.tau = rig._alpha, rig._R, rig._tau
        self.I_lim = 0.8 * rig.I_max_A

    def skin(self, X: np.ndarray) -> np.ndarray:
        return self.surf_f @ X + self.surf_f0

    def run(self, x0: np.ndarray, U: np.ndarray, heat: list | None = None) -> np.ndarray:
        """Skin temperature at samples 0..K for current columns U (K × B): returns (K + 1) × B, °C.
        ``heat``: a list that receives the heat flow into the finger at each sample (rows of B), W."""
        K, B = U.shape
        X = np.repeat(x0[:, None], B, axis=1)
        out = np.empty((K + 1, B))
        out[0] = self.skin(X)
        if heat is not None:
            heat.append(self.q_f @ X + self.q_f0)
        Phi, Bcat = self.Phi, self.Bcat
        for k in range(K):
            Y = Phi @ X
            u0, u1, v0, v1 = plate_heats(
                self.rows, self.alpha, self.tau, self.R, U[k], X[1], X[2], Y[1], Y[2]
            )
            X = Y + Bcat @ np.vstack((np.ones(B), u0, u1, v0, v1))
            out[k + 1] = self.skin(X)
            if heat is not None:
                heat.append(self.q_f @ X + self.q_f0)
        return out


def cooling_peak_A(alpha_V_per_K: float, R_ohm: float, T_cold_C: float = 0.0) -> float:
    """The current of greatest Peltier cooling at a cold plate at T_cold_C, αT/R, A (more current
    warms; the lowest plausible plate temperature gives the smallest peak). From the plant's own α and R:
    a node finds it from its identified model instead (telethermo.control.cooling_limit).

    >>> round(cooling_peak_A(0.05, 3.9, 0.0), 2)
    3.5
    """
    return alpha_V_per_K * (T_cold_C + 273.15) / R_ohm


def _smooth_abs(e: np.ndarray) -> np.ndarray:
    return np.sqrt(e * e + EPS_C * EPS_C)


def clamp_excess(skin_C: np.ndarray, clamp_C: tuple[float, float]) -> np.ndarray:
    """How far each skin sample lies beyond [lo, hi], °C (0 inside).

    >>> clamp_excess(np.array([14.0, 30.0, 43.2]), (15.0, 43.0)).round(3).tolist()
    [1.0, 0.0, 0.2]
    """
    lo, hi = clamp_C
    return np.maximum(skin_C - hi, 0.0) + np.maximum(lo - skin_C, 0.0)


def _optimise(
    plant: BatchedPlant,
    x0: np.ndarray,
    fixed: np.ndarray,
    n_free: int,
    ref: np.ndarray,
    weights: np.ndarray,
    u_init: float,
    maxiter: int,
    clamp_C: tuple[float, float] | None = None,
    restarts_A: tuple[float, ...] = (),
) -> np.ndarray:
    """Currents after ``fixed`` (n_free of them) minimising Σ weights·|skin − ref| over the samples
    len(fixed)+1 .. len(fixed)+n_free (sample j depends on the currents before it); with ``clamp_C`` plus the
    clamp's penalty on each of those samples. The search starts from ``u_init`` and from each current of
    ``restarts_A`` (A, held over the free samples); the lowest objective wins."""
    nf = len(fixed)
    K = nf + n_free

    def skins(U: np.ndarray) -> np.ndarray:
        return plant.run(x0, U)[1 : K + 1]  # samples 1..K

    def f_and_g(u: np.ndarray) -> tuple[float, np.ndarray]:
        base = np.concatenate([fixed, u])
        U = np.repeat(base[:, None], n_free + 1, axis=1)
        U[nf + np.arange(n_free), 1 + np.arange(n_free)] += FD_STEP_A
        S = skins(U)
        E = (_smooth_abs(S - ref[1 : K + 1, None]) * weights[1 : K + 1, None]).sum(axis=0)
        if clamp_C is not None:
            E = E + CLAMP_WEIGHT * (clamp_excess(S[nf:], clamp_C) ** 2).sum(axis=0)
        return float(E[0]), (E[1:] - E[0]) / FD_STEP_A

    lim = plant.I_lim
    runs = [
        minimize(
            f_and_g,
            np.full(n_free, float(np.clip(u0, -lim, lim))),
            jac=True,
            method="L-BFGS-B",
            bounds=[(-lim, lim)] * n_free,
            options={"maxiter": maxiter, "ftol": 1e-12, "gtol": 1e-9},
        )
        for u0 in (u_init, *restarts_A)
    ]
    best = min(runs, key=lambda r: r.fun)  # the first of equals: without restarts, the one run
    return np.clip(best.x, -lim, lim)


def causal_bound(
    plant: BatchedPlant,
    w: Window,
    *,
    maxiter: int = 200,
    clamp_C: tuple[float, float] | None = None,
    restarts_A: tuple[float, ...] = (),
) -> np.ndarray:
    """Currents of the causal bound (see module docstring): n_pre + n_early values, A; with ``clamp_C``
    (lo, hi), °C, the clamped bound. ``restarts_A``: further starting currents of each stage's search (the
    early stage otherwise starts from the last pre-touch current). Heat into the pad, αIT − ½I²R, is concave
    in the current: past the maximum-cooling current αT/R more cooling current warms, so where αT/R lies
    inside the limit a search started past it can stop at a local optimum on the limit
    (:func:`cooling_peak_A`)."""
    n_pre, n_all = w.n_pre, w.n_pre + w.n_early
    wt = np.zeros(n_all + 1)
    wt[1:n_pre] = 1.0  # samples before the touch (the touch is at sample n_pre)
    u_pre = _optimise(
        plant, w.x0, np.zeros(0), n_pre - 1, _pad(w.ref_C), wt, 0.0, maxiter, clamp_C, restarts_A
    )
    u_pre = np.append(u_pre, u_pre[-1])  # the last pre current: held (it only acts at the touch)
    wt = np.zeros(n_all + 1)
    wt[n_pre:n_all] = 1.0  # the early samples (the first one is fixed by the past)
    u_early = _optimise(
        plant, w.x0, u_pre, w.n_early - 1, _pad(w.ref_C), wt, float(u_pre[-1]), maxiter, clamp_C, restarts_A
    )
    return np.concatenate([u_pre, u_early, u_early[-1:]])[:n_all]


def foresight_bound(
    plant: BatchedPlant, w: Window, weight_pre: float, *, maxiter: int = 200, u_init: np.ndarray | None = None
) -> np.ndarray:
    """Currents minimising weight_pre·pre + (1 − weight_pre)·early with knowledge of the touch, A."""
    n_pre, n_all = w.n_pre, w.n_pre + w.n_early
    wt = np.zeros(n_all + 1)
    wt[1:n_pre] = weight_pre / (n_pre - 1)
    wt[n_pre:n_all] = (1.0 - weight_pre) / w.n_early
    u = _optimise(plant, w.x0, np.zeros(0), n_all - 1, _pad(w.ref_C), wt * n_all, 0.0, maxiter)
    return np.append(u, u[-1])


def _pad(ref: np.ndarray) -> np.ndarray:
    return np.append(ref, ref[-1])


def window_errors(skin: np.ndarray, w: Window) -> dict[str, float]:
    """pre / early / window mean |skin − ref| (the figures of telethermo.offline.transparency)."""
    e = np.abs(skin[: w.n_pre + w.n_early] - w.ref_C)
    return {
        "pre_C": float(e[: w.n_pre].mean()),
        "early_C": float(e[w.n_pre :].mean()),
        "window_C": float(e.mean()),
    }


def replay(rig_factory, w: Window, currents_A: np.ndarray, period_s: float) -> np.ndarray:
    """Skin at every sample of the window when ``currents_A`` drive a fresh ``SimRig`` set to the window's
    start state (the check that the batched plant is the simulator), °C."""
    rig = rig_factory()
    rig.x = w.x0.copy()
    rig.t_s = w.t0_s
    rig._next_event = rig.schedule.next_event_after(rig.t_s + 1e-9)
    out = [rig.truth().T_surface_C]
    for I in currents_A[:-1]:
        rig.apply_current(float(I))
        rig.advance(period_s)
        out.append(rig.truth().T_surface_C)
    return np.array(out)


def matched_start(rig: SimRig, finger_cells_C: np.ndarray) -> np.ndarray:
    """The master rig's state with the finger's cells set to ``finger_cells_C``, the pad plate and the sensor
    at the finger's surface temperature, the TEM's sink-side plate at the heat sink's present value."""
    cfg = rig.cfg
    x = rig.x.copy()
    body = cfg.body
    base = 3 + rig.sensor.n
    x[base : base + body.n] = finger_cells_C
    f, f0 = body.system.face_functional(0, "front")
    T_surf = float(f @ finger_cells_C + f0)
    x[cfg.i_p] = T_surf
    x[3:base] = T_surf
    x[cfg.i_s] = x[cfg.i_sink]
    x[-1] = 0.0
    return x
