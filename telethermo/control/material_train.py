"""Training the calibrated material classifier's networks on reference touches (offline; pure numpy).

A lab re-calibrates on touches of its own reference samples (docs/material_id.md); the shipped file is built
the same way on simulated ones (bench/material_calibrate.py). :func:`build_calibration` maps the touch vectors
to the networks' input (telethermo.control.material_calib.input_map: the rig's noise whitened) and trains
``n_nets`` fully connected ReLU networks (:func:`train_network`) by Adam on the cross-entropy of the material,
each from its own seed; their mean posterior is the classifier's.

Deterministic for given data and seeds (numpy's default generator, float32 arithmetic on one machine).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from telethermo.control.material_calib import Calibration, input_map, inputs, log_softmax, posterior


@dataclass(frozen=True)
class TrainSettings:
    """How the networks are trained (chosen on a development set, docs/material_id.md).

    Attributes:
        hidden: units per hidden layer; layers: hidden layers.
        epochs: passes over the references; batch: references per step.
        lr: Adam's peak step (linear warm-up over ``warmup`` steps, then a cosine decay to zero).
        weight_decay: L2 pull of every parameter towards zero per step, in units of the step.
        n_nets: ensemble members (each its own seed: ``seed + j``; on the development set two members were no
            better than one).
    """

    hidden: int = 512
    layers: int = 3
    epochs: int = 40
    batch: int = 256
    lr: float = 2e-3
    warmup: int = 500
    weight_decay: float = 1e-5
    n_nets: int = 1
    seed: int = 0


def _init(rng: np.random.Generator, sizes: list[int]) -> list[np.ndarray]:
    """He-initialised weights and zero biases, flattened [W0, b0, W1, b1, …] (float32)."""
    out = []
    for a, b in zip(sizes[:-1], sizes[1:]):
        out += [(rng.standard_normal((a, b)) * np.sqrt(2.0 / a)).astype(np.float32), np.zeros(b, np.float32)]
    return out


def _gradients(P: list[np.ndarray], x: np.ndarray, t: np.ndarray) -> list[np.ndarray]:
    """Gradients of the mean cross-entropy of targets ``t`` over the batch ``x`` (backpropagation)."""
    hs = [x]
    for i in range(0, len(P) - 2, 2):
        hs.append(np.maximum(hs[-1] @ P[i] + P[i + 1], 0.0))
    g = np.exp(log_softmax(hs[-1] @ P[-2] + P[-1]))
    g[np.arange(len(t)), t] -= 1.0
    g /= len(t)
    grads = [np.empty(0)] * len(P)
    for li in range(len(P) // 2 - 1, -1, -1):
        grads[2 * li], grads[2 * li + 1] = hs[li].T @ g, g.sum(axis=0)
        if li > 0:
            g = (g @ P[2 * li].T) * (hs[li] > 0)
    return grads


def train_network(
    X: np.ndarray, y: np.ndarray, n_classes: int, s: TrainSettings, seed: int
) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
    """One network's layers trained on inputs ``X`` (N × in) and class indices ``y``."""
    X, y = np.asarray(X, np.float32), np.asarray(y, int)
    rng = np.random.default_rng(seed)
    P = _init(rng, [X.shape[1]] + [s.hidden] * s.layers + [n_classes])
    m, v = [np.zeros_like(p) for p in P], [np.zeros_like(p) for p in P]
    n_batches = max(len(y) // s.batch, 1)
    total, k = s.epochs * n_batches, 0
    for _ in range(s.epochs):
        order = rng.permutation(len(y))
        for bi in range(n_batches):
            idx = order[bi * s.batch : (bi + 1) * s.batch]
            grads = _gradients(P, X[idx], y[idx])
            k += 1
            lr = s.lr * min(1.0, k / s.warmup) * 0.5 * (1.0 + np.cos(np.pi * k / total))
            for i, gr in enumerate(grads):
                gr = gr + s.weight_decay * P[i]
                m[i] = 0.9 * m[i] + 0.1 * gr
                v[i] = 0.999 * v[i] + 0.001 * gr * gr
                P[i] -= (lr * (m[i] / (1.0 - 0.9**k)) / (np.sqrt(v[i] / (1.0 - 0.999**k)) + 1e-8)).astype(
                    np.float32
                )
    return tuple((P[i], P[i + 1]) for i in range(0, len(P), 2))


def accuracy(cal: Calibration, V: np.ndarray, y: np.ndarray) -> float:
    """Fraction of touch vectors ``V`` (N × 2·n_win, °C) whose likeliest class is ``y``."""
    X = inputs(cal.center, cal.whiten, cal.scale, V)
    return float(np.mean(np.argmax(posterior(cal, X), axis=1) == np.asarray(y)))


def build_calibration(
    V: np.ndarray,
    y: np.ndarray,
    classes: list[str],
    dt_s: float,
    q_weight_K_per_W: float,
    noise_cov: np.ndarray | None = None,
    reg: float = 0.01,
    settings: TrainSettings = TrainSettings(),
    info: str = "",
) -> Calibration:
    """A calibration from reference touch vectors ``V`` (N × 2·n_win, °C) and their class indices ``y``: the
    input map (``noise_cov``: the touch vector's noise covariance, °C², whitened with floor ``reg``) and
    ``settings.n_nets`` networks trained on all references."""
    V, y = np.asarray(V, float), np.asarray(y, int)
    center, whiten, scale = input_map(V, noise_cov, reg)
    X = inputs(center, whiten, scale, V)
    nets = tuple(
        train_network(X, y, len(classes), settings, settings.seed + j) for j in range(settings.n_nets)
    )
    return Calibration(
        tuple(classes),
        float(dt_s),
        V.shape[1] // 2,
        float(q_weight_K_per_W),
        center,
        whiten,
        scale,
        nets,
        info,
    )
