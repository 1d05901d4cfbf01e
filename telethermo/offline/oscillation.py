"""Oscillation in settled contact: the figure that shows a limit cycle a good headline can hide (issue 22).

In each touch's settled contact, its last 1.5 s (and not before t_on + 1 s), the operator's skin on the
display
and the direct-touch finger's skin are each detrended (a parabola: the later phase's slow drift and the tail
of a
saturated metal touch's recovery are no oscillation; a limit cycle of 0.7 Hz or more keeps its swings) and
their power between 0.3 and 5 Hz is summed (Parseval over the window's FFT), as an RMS in °C; likewise the
display's current, in A. A sustained cycle lives through the end of the touch; a single overshoot after
saturation does not. The **oscillation ratio** of a touch is

    ratio = skin_band_rms_C / max(direct_band_rms_C, FLOOR_C)

with FLOOR_C = 0.05 °C (a session **oscillates** when a touch's ratio exceeds :data:`OSCILLATION_LIMIT` while
the
display's current swings too, by more than :data:`CURRENT_SWING_FRACTION` of the current limit in the same
band:
a skin that moves under a steady current is the pad's passive settling after a saturated metal touch, not a
loop
oscillation; both figures are reported): a direct touch's settled skin is almost still (0.001 °C here), and a
fluctuation of
0.05 °C RMS (0.14 °C peak to peak for a sine) lies at the skin's ≈ 0.1 °C difference threshold: nothing anyone
feels as an oscillation. (The base scene's worst touch, the first aluminium after a saturated 1.3 s, leaves
0.07 °C of its recovery in the window: ratio 1.4; the issue's limit cycle gives ≈ 1.2 °C: ratio ≈ 24.) A
session oscillates when its worst ratio
exceeds :data:`OSCILLATION_LIMIT` (1.5) with the current swinging. Pure functions (arrays in, numbers out).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

BAND_HZ = (0.3, 5.0)
SETTLE_S = 1.0
WINDOW_S = 1.5
DETREND_ORDER = 2
FLOOR_C = 0.05
OSCILLATION_LIMIT = 1.5
#: a current swing (band RMS) below this share of the current limit drives no oscillation
CURRENT_SWING_FRACTION = 0.02


def band_rms(y: np.ndarray, dt_s: float, band_Hz: tuple[float, float] = BAND_HZ) -> float:
    """RMS of ``y``'s content between band_Hz[0] and band_Hz[1] after removing a parabola (same unit as y).

    >>> t = np.arange(0, 4, 0.01)        # 4 s: the doctest's sines are whole cycles
    >>> 0.67 < band_rms(np.sin(2 * np.pi * 1.0 * t) + 0.5 * t, 0.01) < 0.72   # 1 Hz sine, RMS 1/√2, on a ramp
    True
    >>> band_rms(np.sin(2 * np.pi * 20.0 * t), 0.01) < 0.01           # 20 Hz lies outside the band
    True
    """
    y = np.asarray(y, dtype=float)
    if len(y) < 8 or not np.all(np.isfinite(y)):
        return math.nan
    x = np.arange(len(y))
    y = y - np.polyval(np.polyfit(x, y, DETREND_ORDER), x)
    spec = np.fft.rfft(y)
    f = np.fft.rfftfreq(len(y), dt_s)
    sel = (f >= band_Hz[0]) & (f <= band_Hz[1])
    w = np.where((f == 0) | (f == f[-1]) & (len(y) % 2 == 0), 1.0, 2.0)  # one-sided spectrum weights
    return float(math.sqrt(np.sum(w[sel] * np.abs(spec[sel]) ** 2)) / len(y))


def oscillation_figures(
    t: np.ndarray,
    skin_C: np.ndarray,
    ref_C: np.ndarray,
    current_A: np.ndarray,
    contacts: list[dict[str, Any]],
    current_limit_A: float = 2.4,
) -> dict[str, Any]:
    """Per-touch band RMS of the display's skin, the direct touch's skin and the display's current in settled
    contact, each touch's ratio, and the worst (see the module docstring)."""
    dt = float(t[1] - t[0]) if len(t) > 1 else math.nan
    per = []
    for c in contacts:
        m = (t >= max(c["t_on_s"] + SETTLE_S, c["t_off_s"] - WINDOW_S)) & (t < c["t_off_s"])
        if int(m.sum()) < 8:
            continue
        s, r, i = band_rms(skin_C[m], dt), band_rms(ref_C[m], dt), band_rms(current_A[m], dt)
        ratio = s / max(r, FLOOR_C)
        swing = i > CURRENT_SWING_FRACTION * current_limit_A
        per.append(
            {
                "object": c.get("object", ""),
                "t_on_s": c["t_on_s"],
                "skin_band_rms_C": s,
                "direct_band_rms_C": r,
                "current_band_rms_A": i,
                "ratio": ratio,
                "oscillating": bool(ratio > OSCILLATION_LIMIT and swing),
            }
        )
    ratios = [p["ratio"] for p in per if math.isfinite(p["ratio"])]
    worst = max(ratios) if ratios else math.nan
    return {
        "band_Hz": list(BAND_HZ),
        "floor_C": FLOOR_C,
        "limit": OSCILLATION_LIMIT,
        "current_swing_A": CURRENT_SWING_FRACTION * current_limit_A,
        "worst_ratio": worst,
        "oscillating": any(p["oscillating"] for p in per),
        "skin_band_rms_max_C": max((p["skin_band_rms_C"] for p in per), default=math.nan),
        "current_band_rms_max_A": max((p["current_band_rms_A"] for p in per), default=math.nan),
        "per_touch": per,
    }
