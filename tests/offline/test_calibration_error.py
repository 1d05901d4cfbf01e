"""The calibration error's floors (telethermo/offline/calibration_error.py, the material bench's scores):
the worst-stratum ECE's baseline is what a perfectly calibrated classifier shows, and it can tell a
miscalibrated one apart."""

import numpy as np

from telethermo.offline.calibration_error import ece, ece_floor, ece_worst_floor


def _posteriors(n: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(0.2, 1.0, n)


def test_the_worst_of_several_strata_sits_above_each_strata_own_floor():
    posts = [_posteriors(300, s) for s in range(8)]
    joint = ece_worst_floor(posts)
    assert joint is not None
    assert joint > max(ece_floor(p) or 0.0 for p in posts) + 0.005


def test_the_worst_stratum_floor_falls_with_the_number_of_touches():
    small = ece_worst_floor([_posteriors(300, s) for s in range(8)])
    large = ece_worst_floor([_posteriors(2700, s) for s in range(8)])
    assert small is not None and large is not None
    assert 2.0 < small / large < 4.5  # about √9 = 3: sampling noise


def test_a_miscalibrated_stratum_stands_out_of_the_floor():
    rng = np.random.default_rng(5)
    post = np.full(900, 0.9)
    right = rng.random(900) < 0.75  # says 0.9, right 0.75 of the time
    e, floor = ece(post, right), ece_worst_floor([post])
    assert e is not None and floor is not None
    assert abs(e - 0.15) < 0.04 and floor < 0.03


def test_no_answers_no_floor():
    assert ece_worst_floor([np.array([])]) is None
