"""Measurement chain of a rig: seeded Gaussian noise, ADC quantisation, 2nd-order low-pass digital filter.

guiatni §3.1 filters the temperature and heat-flux signals with a second-order low-pass digital filter but
gives no cutoff. We use a Butterworth biquad (bilinear transform with pre-warping) at ``cutoff_Hz`` = 5 Hz by
default (100 Hz sampling: −3 dB at 5 Hz, group delay ≈ 45 ms at DC; well above the ~1 Hz content of a
contact transient as seen through the sensor, well below the Nyquist frequency), capped at 0.4·Nyquist
for slow sampling. The filter starts at rest on the first value (no start-up transient).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, slots=True)
class NoiseParams:
    """Sensor noise and converter resolution.

    Attributes:
        T_sigma_C: thermocouple noise (1 σ), °C.
        Q_sigma_W: heat-flux noise (1 σ), W.
        T_lsb_C: ADC step of the temperature channel, °C (0 = no quantisation).
        Q_lsb_W: ADC step of the flux channel, W.
        cutoff_Hz: −3 dB frequency of the 2nd-order Butterworth low-pass, Hz (0 = no filter).
        enabled: False turns noise off (quantisation and filter stay).
    """

    T_sigma_C: float = 0.02
    Q_sigma_W: float = 0.002
    T_lsb_C: float = 100.0 / 65536  # 16-bit over a 100 °C span
    Q_lsb_W: float = 10.0 / 65536  # 16-bit over ±5 W
    cutoff_Hz: float = 5.0
    enabled: bool = True


def butter2_lowpass(cutoff_Hz: float, fs_Hz: float) -> tuple[tuple[float, float, float], tuple[float, float]]:
    """Coefficients (b0, b1, b2), (a1, a2) of a 2nd-order Butterworth low-pass (bilinear, pre-warped)."""
    fc = min(cutoff_Hz, 0.4 * fs_Hz / 2.0)
    k = math.tan(math.pi * fc / fs_Hz)
    q = 1.0 / math.sqrt(2.0)
    norm = 1.0 / (1.0 + k / q + k * k)
    b0 = k * k * norm
    a1 = 2.0 * (k * k - 1.0) * norm
    a2 = (1.0 - k / q + k * k) * norm
    return (b0, 2.0 * b0, b0), (a1, a2)


class Biquad:
    """Direct-form-II-transposed biquad; unity DC gain."""

    __slots__ = ("b0", "b1", "b2", "a1", "a2", "z1", "z2", "started")

    def __init__(self, cutoff_Hz: float, fs_Hz: float) -> None:
        (self.b0, self.b1, self.b2), (self.a1, self.a2) = butter2_lowpass(cutoff_Hz, fs_Hz)
        self.z1 = self.z2 = 0.0
        self.started = False

    def reset(self, y: float) -> None:
        """Put the filter at rest on the value ``y``."""
        self.z1 = y * (1.0 - self.b0)
        self.z2 = y * (self.b2 - self.a2)
        self.started = True

    def __call__(self, x: float) -> float:
        if not self.started:
            self.reset(x)
        y = self.b0 * x + self.z1
        self.z1 = self.b1 * x - self.a1 * y + self.z2
        self.z2 = self.b2 * x - self.a2 * y
        return y


class Channel:
    """One measured signal: true value -> + noise -> quantised -> filtered."""

    __slots__ = ("sigma", "lsb", "filt", "rng", "_buf", "_i")
    BLOCK = 1024

    def __init__(
        self, sigma: float, lsb: float, cutoff_Hz: float, fs_Hz: float, rng: np.random.Generator
    ) -> None:
        self.sigma, self.lsb, self.rng = sigma, lsb, rng
        self.filt = Biquad(cutoff_Hz, fs_Hz) if cutoff_Hz > 0 else None
        self._buf: list[float] = []
        self._i = 0

    def __call__(self, true_value: float) -> float:
        v = true_value
        if self.sigma:
            if self._i >= len(self._buf):  # draw normals in blocks (same stream for a seed)
                self._buf = (self.sigma * self.rng.standard_normal(self.BLOCK)).tolist()
                self._i = 0
            v += self._buf[self._i]
            self._i += 1
        if self.lsb:
            v = self.lsb * round(v / self.lsb)
        return self.filt(v) if self.filt is not None else v
