"""Contact resistance between the pad (or the finger) and what it touches, as a function of force.

yamamoto Fig. 4: the resistance falls as the force grows; above ~600 gf (5.9 N) there is almost none. Model:

    R''(F) = R1 · (F_perfect/F − 1)/(F_perfect − 1)   for 0 < F < F_perfect   (m²·K/W; R''(1 N) = R1)
    R''(F) = 0                                          for F ≥ F_perfect      (perfect contact)

continuous at F_perfect, and diverging as F → 0 (no force, no contact).
"""
from __future__ import annotations

import math


def contact_resistance_m2K_W(force_N: float, R_at_1N_m2K_W: float = 5e-4, F_perfect_N: float = 6.0) -> float:
    """Specific contact resistance at ``force_N``, m²·K/W (0 = perfect contact, inf = no contact)."""
    if not force_N > 0:
        return math.inf
    if force_N >= F_perfect_N:
        return 0.0
    return R_at_1N_m2K_W * (F_perfect_N / force_N - 1.0) / (F_perfect_N - 1.0)
