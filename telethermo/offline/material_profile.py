"""The profiled-likelihood classifier that knows the simulator, on the slave's own record (issue 23).

The envelope's oracles (telethermo/offline/material_oracle.py, bench/material_oracle_global.py) add white
noise to the unfiltered true signals and profile each candidate's nuisances (object temperature, force,
thickness) in a *linearisation*: one projection onto the span of the trace's sensitivities. A wrong material
whose trace bends towards the touch's as its nuisances move gets, in that projection, a larger residual than
its best fit has, so the linearised oracle is kind to the truth. Here the nuisances are fitted for real.

A touch's record is what the slave saw (the filtered, noisy, closed-loop T_sensor and Q of
telethermo/offline/material_touches.simulate_touch): over the answer's window from the detector's contact
sample, each signal's change since the mean of the :data:`PRE` samples before it (:func:`record_vector`),
whitened by the covariance of that vector's noise (the rig's noise through its low-pass and the controller's
response to it: :func:`noise_covariance`, estimated from paired noisy and noise-free simulations). Each
candidate's trace is the same vector of a noise-free simulation on the same sample grid, with the same onset
and room (:class:`TouchModel`); its ln force, ln thickness and object temperature (and, when asked, the
onset within its sample) are fitted by Levenberg–Marquardt on the simulated traces themselves
(:func:`lm_fit`), bounded to the envelope. The candidate with the least residual is the answer: the
generalised likelihood-ratio test, with the simulator as the model. :func:`lm_fit` also returns the residual
of the linearised projection from its start (the local oracle's form), so the two can be set side by side on
the same record and metric.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from telethermo.control.material_calib import whitener
from telethermo.offline.material_touches import PERIOD_S, simulate_touch
from telethermo.sim.measurement import NoiseParams

#: samples before the contact sample whose mean each signal's change is taken from
PRE = 20
#: the fitted parameters: ln force (ln N), ln thickness (ln m), object temperature (°C), onset shift (s)
N_PARAMS = 4
#: the envelope's bounds of each parameter (issue 22's: force 0.5–20 N, thickness 0.3–20 mm, objects 5–50 °C;
#: the onset within ± one sample)
LOWER = np.array([math.log(0.5), math.log(0.3e-3), 5.0, -PERIOD_S])
UPPER = np.array([math.log(20.0), math.log(20e-3), 50.0, PERIOD_S])
#: finite-difference steps of the Jacobian, one per parameter
STEPS = np.array([0.02, 0.02, 0.1, 0.0005])
#: the whitener's floor, relative to the mean noise variance (material_calib.whitener)
WHITEN_REG = 1e-2


def record_vector(T: np.ndarray, Q: np.ndarray, i0: int, n_win: int) -> np.ndarray | None:
    """[T_sensor's change (°C) ..., Q's change (W) ...] over ``n_win`` samples from sample ``i0``, each since
    the mean of the :data:`PRE` samples before it (None: the record does not hold the window)."""
    if i0 < PRE or i0 + n_win > T.size:
        return None
    return np.concatenate(
        [T[i0 : i0 + n_win] - T[i0 - PRE : i0].mean(), Q[i0 : i0 + n_win] - Q[i0 - PRE : i0].mean()]
    )


def window_block(cov: np.ndarray, n_full: int, n_win: int) -> np.ndarray:
    """The covariance of the first ``n_win`` samples of each signal from that of ``n_full`` (pure)."""
    idx = np.r_[0:n_win, n_full : n_full + n_win]
    return cov[np.ix_(idx, idx)]


@dataclass(frozen=True)
class TouchModel:
    """The simulator of one touch's probe, room and onset: any candidate's whitened trace.

    Attributes:
        params: the probe rig's parameters; core: the slave core's (None: its defaults).
        ambient_C: the room, °C; T_probe_C: where the probe rests before the touch, °C.
        t_on_s: the touch's onset, s; i0: the record's contact sample; n_win: window samples.
        whiten: the noise's whitening (2·n_win square, material_calib.whitener).
    """

    params: Any
    core: Any
    ambient_C: float
    T_probe_C: float
    t_on_s: float
    i0: int
    n_win: int
    whiten: np.ndarray

    def trace(self, mat: str, theta: np.ndarray) -> np.ndarray:
        """The whitened noise-free trace of ``mat`` at ``theta`` (ln F, ln d, T_o, onset shift)."""
        t_on = self.t_on_s + float(theta[3])
        T, Q, _, _, _ = simulate_touch(
            self.params,
            mat,
            math.exp(float(theta[1])),
            float(theta[2]),
            math.exp(float(theta[0])),
            self.T_probe_C,
            seed=0,
            t_on_s=t_on,
            noise=NoiseParams(enabled=False),
            identify=False,
            ambient_C=self.ambient_C,
            post_s=(self.i0 + self.n_win + 2) * PERIOD_S - t_on,
            core_params=self.core,
        )
        v = record_vector(T, Q, self.i0, self.n_win)
        if v is None:
            raise ValueError(f"model record too short for the window (i0 {self.i0}, n_win {self.n_win})")
        return np.asarray(self.whiten @ v)


@dataclass(frozen=True)
class Fit:
    """One candidate's profiled fit: ``cost`` the whitened squared residual at ``theta``; ``linearised`` the
    residual of one linear projection from the start (the local oracle's form); ``sims`` traces simulated;
    ``fisher`` JᵀJ of the free parameters at the last Jacobian (the whitened trace's information about them,
    for :func:`laplace_log_evidence`; empty when nothing was free)."""

    cost: float
    theta: np.ndarray
    linearised: float
    sims: int
    fisher: np.ndarray
    free: np.ndarray


def lm_fit(
    trace: Callable[[np.ndarray], np.ndarray],
    x: np.ndarray,
    theta0: np.ndarray,
    free: np.ndarray,
    iters: int = 4,
) -> Fit:
    """Levenberg–Marquardt of ``trace(theta)`` to the whitened record ``x`` over the ``free`` parameters
    (bool mask), from ``theta0``, inside :data:`LOWER`–:data:`UPPER`; a step is taken only when the simulated
    residual falls, so the cost never exceeds the start's."""
    theta = np.clip(np.asarray(theta0, float), LOWER, UPPER)
    f0 = trace(theta)
    cost, sims, lam = float(np.sum((x - f0) ** 2)), 1, 1e-2
    idx = np.flatnonzero(free)
    linearised = cost
    A = np.zeros((idx.size, idx.size))
    for it in range(iters if idx.size else 0):
        J = np.empty((x.size, idx.size))
        for c, q in enumerate(idx):
            h = STEPS[q] if theta[q] + STEPS[q] <= UPPER[q] else -STEPS[q]
            e = np.zeros(N_PARAMS)
            e[q] = h
            J[:, c] = (trace(theta + e) - f0) / h
            sims += 1
        A, g = J.T @ J, J.T @ (x - f0)
        D = np.diag(np.diag(A) + 1e-9 * float(np.max(np.diag(A))) + 1e-12)
        if it == 0:
            linearised = cost - float(g @ np.linalg.solve(A + 1e-9 * D, g))
        for _ in range(3):
            step = np.zeros(N_PARAMS)
            step[idx] = np.linalg.solve(A + lam * D, g)
            cand = np.clip(theta + step, LOWER, UPPER)
            f1 = trace(cand)
            sims += 1
            c1 = float(np.sum((x - f1) ** 2))
            if c1 < cost:
                theta, f0, cost, lam = cand, f1, c1, lam / 3.0
                break
            lam *= 10.0
    return Fit(cost, theta, linearised, sims, A, idx)


def noise_covariance(
    params: Any, core: Any, mats: list[str], n: int, n_win: int, seed: int = 0
) -> np.ndarray:
    """Covariance (2·n_win square) of :func:`record_vector`'s noise at the rig's default noise: ``n`` touches
    (the ``mats`` in turn, force, thickness and object drawn from ``seed``, the probe at 33.65 °C in a 25 °C
    room) simulated with and without noise, the same onset."""
    rng = np.random.default_rng(seed)
    diffs = []
    for k in range(n):
        mat = mats[k % len(mats)]
        d = math.exp(rng.uniform(math.log(0.3e-3), math.log(20e-3)))
        f = math.exp(rng.uniform(math.log(0.5), math.log(20.0)))
        T_o = float(rng.uniform(8.0, 48.0))
        out = []
        for noise, s in ((NoiseParams(), 1000 + k), (NoiseParams(enabled=False), 0)):
            T, Q, i0, _, _ = simulate_touch(
                params,
                mat,
                d,
                T_o,
                f,
                33.65,
                seed=s,
                t_on_s=0.205,
                noise=noise,
                identify=False,
                post_s=(n_win + 5) * PERIOD_S,
                core_params=core,
            )
            out.append((record_vector(T, Q, i0, n_win), i0))
        (a, ia), (b, ib) = out
        if a is not None and b is not None and ia == ib:
            diffs.append(a - b)
    return np.cov(np.array(diffs).T)


def whitening(cov: np.ndarray, noise_x: float = 1.0) -> np.ndarray:
    """The whitener of :func:`noise_covariance` ``cov`` scaled to a noise ``noise_x`` times the default."""
    return whitener(cov * noise_x**2, WHITEN_REG)


def with_onset_free(free: np.ndarray) -> np.ndarray:
    """``free`` with the onset shift freed too."""
    out = np.array(free, bool)
    out[3] = True
    return out


KNOWN_ONSET = np.array([True, True, True, False])


def laplace_log_evidence(fit: Fit) -> float:
    """ln p(record | material) up to a constant shared by every candidate, by Laplace's approximation about
    the fit: −cost/2 plus, along each eigen-direction of the free parameters' information, the log of the
    width the record leaves it (√(2π/λ)), capped at the envelope's extent along that direction (the prior,
    uniform in ln F, ln d, T_o and the onset over :data:`LOWER`–:data:`UPPER`, is flat; its volume is shared).
    A wrong material that fits only on a narrow ridge of its nuisances is weighed by how narrow, which the
    maximum likelihood (``cost`` alone) does not."""
    out = -0.5 * fit.cost
    if fit.free.size == 0:
        return out
    lam, vec = np.linalg.eigh(0.5 * (fit.fisher + fit.fisher.T))
    span = (UPPER - LOWER)[fit.free]
    for k in range(lam.size):
        extent = 1.0 / max(float(np.max(np.abs(vec[:, k]) / span)), 1e-12)
        width = math.sqrt(2.0 * math.pi / lam[k]) if lam[k] > 0.0 else extent
        out += math.log(min(width, extent) / extent)
    return out
