"""Measurement chain: filter response, noise statistics, quantisation, determinism."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import freqz

from telethermo import sim
from telethermo.sim.measurement import Biquad, Channel, butter2_lowpass


def test_filter_is_2nd_order_butterworth_at_the_cutoff():
    b, a = butter2_lowpass(5.0, 100.0)
    w, h = freqz(b, (1.0, *a), worN=[0.0, 5.0, 20.0, 40.0], fs=100.0)
    mag = np.abs(h)
    assert mag[0] == pytest.approx(1.0, abs=1e-12)  # unity DC gain
    assert 20 * math.log10(mag[1]) == pytest.approx(-3.01, abs=0.05)  # −3 dB at the cutoff
    assert 20 * math.log10(mag[2]) < -22.0  # ≈ −40 dB/decade beyond
    assert 20 * math.log10(mag[3]) < 20 * math.log10(mag[2]) - 8.0


def test_filter_starts_at_rest_and_tracks_a_step():
    f = Biquad(5.0, 100.0)
    assert [f(25.0) for _ in range(5)] == pytest.approx([25.0] * 5, abs=1e-12)
    ys = [f(30.0) for _ in range(100)]
    assert ys[-1] == pytest.approx(30.0, abs=1e-6)
    assert max(ys) < 30.0 + 0.05 * 5.0  # Butterworth overshoot ≈ 4 %


def test_noise_level_and_quantisation():
    rng = np.random.default_rng(0)
    ch = Channel(0.05, 0.01, 0.0, 100.0, rng)  # no filter: see the raw noise
    xs = np.array([ch(20.0) for _ in range(20000)])
    assert xs.std() == pytest.approx(0.05, rel=0.05)
    assert xs.mean() == pytest.approx(20.0, abs=0.002)
    assert np.allclose(xs / 0.01, np.round(xs / 0.01), atol=1e-6)


def test_filtered_noise_is_reduced_by_the_filter_bandwidth():
    rig = sim.free_pad_rig(seed=3, noise=True)
    Ts = []
    for _ in range(3000):
        rig.advance(0.01)
        Ts.append(rig.read().T_sensor_C - rig.truth().T_sensor_true_C)
    # Butterworth 5 Hz at 100 Hz: equivalent noise bandwidth ≈ 5.55 Hz of 50 Hz → σ·√(0.111) ≈ 0.33 σ
    assert np.std(Ts[100:]) == pytest.approx(0.02 * 0.333, rel=0.2)


def test_same_seed_same_samples_other_seed_other_noise():
    def samples(seed):
        r = sim.free_pad_rig(seed=seed)
        out = []
        for k in range(300):
            r.apply_current(0.5 if (k // 50) % 2 else -0.5)
            r.advance(0.01)
            out.append((r.read().T_sensor_C, r.read().Q_W))
        return out

    assert samples(7) == samples(7)
    assert samples(7) != samples(8)
