"""Contact resistance between the pad (or the finger) and what it touches, as a function of force.

The real contact area of a soft fingertip (or of the probe's pad) grows with the force, so the contact
conductance keeps rising with force without ever becoming perfect. Model (a power law in the force):

    R''(F) = R1 · (F / 1 N)^(−n)        for F > 0          (m²·K/W; R''(1 N) = R1)
    R''(F) = ∞                          for F ≤ 0          (no force, no contact)

Anchors (yamamoto Fig. 4, a finger on a ceramic plate): at 1 N the resistance visibly slows the skin's
drop (R1 = 5e-4 m²·K/W: a time constant (R''·b_skin)² ≈ 0.5 s for b_skin ≈ 1.5e3 W·s½/(m²·K)), and
"above 600 gf (5.9 N) there is almost no thermal resistance": with n = 2, R''(5.9 N) = 1.4e-5 m²·K/W,
a time constant of 0.5 ms, below one 10 ms control period. The conductance 1/R'' still doubles from 8 to
11 N and rises 6× from 8 to 20 N, so a study of high force sees it (2, 8 and 20 N differ) while the
contact stays finite (tests/sim/test_closed_forms.py checks the simulator against Carslaw & Jaeger's
closed form with this finite conductance at 2, 8 and 20 N).
"""

from __future__ import annotations

import math

#: R''(1 N), m²·K/W (see the module docstring)
DEFAULT_R_AT_1N_M2K_W = 5e-4
#: exponent n of the power law R'' ∝ F^(−n)
DEFAULT_FORCE_EXPONENT = 2.0


def contact_resistance_m2K_W(
    force_N: float,
    R_at_1N_m2K_W: float = DEFAULT_R_AT_1N_M2K_W,
    force_exponent: float = DEFAULT_FORCE_EXPONENT,
) -> float:
    """Specific contact resistance at ``force_N``, m²·K/W (finite for any F > 0; inf = no contact)."""
    if not force_N > 0:
        return math.inf
    try:
        return R_at_1N_m2K_W * force_N ** (-force_exponent)
    except OverflowError:  # a force so small (5e-324 N) that no contact conducts
        return math.inf
