"""Training the material classifier's networks (telethermo/control/material_train.py): it reaches the Bayes
rate of
a problem whose Bayes rate is known, and the calibration it builds classifies as its networks do."""

from __future__ import annotations

import math

import numpy as np

from telethermo.control.material_calib import (
    Calibration,
    classify_vector,
    inputs,
    load_calibration,
    network_input,
    save_calibration,
)
from telethermo.control.material_train import TrainSettings, accuracy, build_calibration, train_network

SMALL = TrainSettings(hidden=32, layers=2, epochs=30, batch=64, lr=3e-3, warmup=100, n_nets=1)


def _xor(n: int, sigma: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Four Gaussian clusters at (±1, ±1) with noise ``sigma`` (plus two noise-only inputs); class = the
    centre's x·y > 0. No line separates them (a linear classifier gets 1/2); the Bayes rule is sign(x·y)."""
    c = rng.choice([-1.0, 1.0], size=(n, 2))
    X = np.concatenate([c + sigma * rng.standard_normal((n, 2)), rng.standard_normal((n, 2))], axis=1)
    return X, (c[:, 0] * c[:, 1] > 0).astype(int)


def _phi(x: float) -> float:
    return 0.5 * (1.0 + math.erf(x / math.sqrt(2.0)))


def test_a_trained_network_reaches_the_bayes_rate_of_a_problem_no_line_separates():
    rng = np.random.default_rng(5)
    sigma = 0.5
    bayes = _phi(1 / sigma) ** 2 + (1 - _phi(1 / sigma)) ** 2  # both coordinates right, or both wrong
    X, y = _xor(4000, sigma, rng)
    net = train_network(X, y, 2, SMALL, seed=1)
    cal = Calibration(("a", "b"), 0.01, 2, 1.0, np.zeros(4), np.eye(4), 1.0, (net,))
    Xt, yt = _xor(20000, sigma, rng)
    got = accuracy(cal, Xt, yt)
    rule = float(np.mean((Xt[:, 0] * Xt[:, 1] > 0) == yt))  # the Bayes rule on the same draws
    assert abs(rule - bayes) < 0.006  # 20000 draws: SE 0.0015
    assert got > rule - 0.015, (got, rule)
    untrained = train_network(X, y, 2, TrainSettings(hidden=32, layers=2, epochs=0, n_nets=1), seed=1)
    assert (
        abs(
            accuracy(Calibration(("a", "b"), 0.01, 2, 1.0, np.zeros(4), np.eye(4), 1.0, (untrained,)), Xt, yt)
            - 0.5
        )
        < 0.1
    )


def test_a_built_calibration_classifies_touch_vectors_as_its_networks_do(tmp_path):
    """Synthetic touch vectors (n_win 6: twelve values, °C), two classes told apart by one fast component
    that a
    large slow one (the nuisance) hides in °C; noise covariance known. The saved and loaded calibration's
    single-touch classification equals the batch accuracy's decisions, and is right where the classes differ
    by many noise units."""
    rng = np.random.default_rng(8)
    n = 3000
    y = rng.integers(2, size=n)
    slow = rng.uniform(-5.0, 5.0, size=n)[:, None] * np.r_[np.ones(6), np.full(6, 0.5)]
    fast = np.where(y[:, None] == 1, 1.0, -1.0) * np.r_[0.0, 0.05, -0.05, np.zeros(9)]
    noise_sd = np.r_[np.full(6, 0.005), np.full(6, 0.02)]
    V = slow + fast + noise_sd * rng.standard_normal((n, 12))
    cal = build_calibration(V, y, ["eps", "copper"], 0.01, 3.0, np.diag(noise_sd**2), 0.0, SMALL, "synthetic")
    cal = load_calibration(save_calibration(cal, tmp_path / "c.npz"))
    assert cal.n_win == 6 and cal.info == "synthetic"
    one = np.array([classify_vector(cal, v)[0] for v in V[:300]])
    batch = np.argmax(
        np.mean(
            [
                np.exp(_log_softmax(_logits(net, inputs(cal.center, cal.whiten, cal.scale, V[:300]))))
                for net in cal.nets
            ],
            axis=0,
        ),
        axis=1,
    )
    assert np.array_equal(one, batch)
    assert accuracy(cal, V, y) > 0.98  # the classes are ≥ 14 noise units apart
    assert (
        abs(float(np.std(inputs(cal.center, cal.whiten, cal.scale, V))) - 1.0) < 0.05
    )  # inputs of order one
    assert np.array_equal(network_input(cal, V[7]), inputs(cal.center, cal.whiten, cal.scale, V[7:8])[0])
    assert classify_vector(cal, np.zeros(5)) is None and classify_vector(cal, np.full(12, np.nan)) is None


def _logits(net, x):
    h = x
    for W, b in net[:-1]:
        h = np.maximum(h @ W + b, 0.0)
    return h @ net[-1][0] + net[-1][1]


def _log_softmax(o):
    o = o - o.max(axis=-1, keepdims=True)
    return o - np.log(np.exp(o).sum(axis=-1, keepdims=True))
