"""The TEM's maximum-cooling current, from its identified model: beyond it more current warms the pad.

The heat a TEM pumps out of its pad is Q_c = α·T_c·|I| − ½·R·I² − K·ΔT (guiatni eq. 5): the Peltier term
grows linearly with the current, the Joule term quadratically, so the cooling peaks at
I* = α·T_c/R and falls beyond it. A datasheet's Imax is about that current; a lab's drive, or a module
with a high resistance and a weak Seebeck coefficient, can allow much more. A controller that asks for
more cooling past I* then heats the pad, asks for still more, and runs away into a surface trip (the
envelope benchmark's high-R conditions: 17 session-long cuts). The limit keeps the cooling current at I*,
where the cooling is the largest the module can give.

The NARMA model (eq. 10) carries the current's immediate effect on the pad as Σ_j b_j(I)·I, with b_j a
polynomial in I. Its derivative is the local input gain, which the physics makes linear in I,
∝ α·T + R·I: it crosses zero at I = −α·T/R = −I*. The identification's PRBS spans a few tenths of an
ampere to about 1 A in both directions, where this gain is well determined (much better than the static
map, which the free pad's slow air loss leaves poorly known), so a straight line fitted to it over the
model's current range and extrapolated to its zero gives I*.

>>> import math
>>> zero_of_linear_gain(np.array([-1.0, 0.0, 1.0]), np.array([1.0, 2.0, 3.0]))
2.0
>>> math.isinf(zero_of_linear_gain(np.array([-1.0, 0.0, 1.0]), np.array([3.0, 2.0, 1.0])))
True
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

#: the pad's coldest operating temperature relative to the identification's (K ratio): I* ∝ T_c, and the
#: pad is identified near room temperature while the cooling limit matters at the cold clamp (15 °C vs 25 °C
#: on the skin side: 288/298)
COLD_SIDE_FACTOR = 0.96
GRID_POINTS = 81


def zero_of_linear_gain(current_A: np.ndarray, gain: np.ndarray) -> float:
    """|I| at which the straight line through (``current_A``, ``gain``) crosses zero on the cooling side
    (I < 0), A; ``math.inf`` when it never does (slope <= 0 or the gain is not positive at 0 A)."""
    slope, g0 = np.polyfit(np.asarray(current_A, dtype=float), np.asarray(gain, dtype=float), 1)
    if not (np.isfinite(slope) and np.isfinite(g0)) or slope <= 0.0 or g0 <= 0.0:
        return math.inf
    return float(g0 / slope)


def max_cooling_current_A(model: Any) -> float:
    """The largest useful cooling current of the rig whose identified model is ``model`` (a TemModel or a
    NarmaModel), A (> 0; ``math.inf`` when the model shows no peak: the Joule term too weak to find).

    I* from the zero of the local input gain (module docstring), times :data:`COLD_SIDE_FACTOR`."""
    narma = getattr(model, "temperature", model)
    lo, hi = (float(v) for v in narma.current_range_A)
    if not hi > lo:
        return math.inf
    I = np.linspace(lo, hi, GRID_POINTS)
    # h(I) = Σ_j b_j(I)·I with b_j(I) = Σ_h θ_b[j, h]·I^h: d/dI Σ_h c_h·I^(h+1) = Σ_h (h+1)·c_h·I^h
    c = np.asarray(narma.theta_b, dtype=float).sum(axis=0)
    gain = np.polynomial.polynomial.polyval(I, c * np.arange(1, c.size + 1))
    i_star = zero_of_linear_gain(I, gain)
    return i_star * COLD_SIDE_FACTOR if math.isfinite(i_star) else math.inf
