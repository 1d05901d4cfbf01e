"""Graded 1D finite-volume grids: thin cells at the contact face, growing geometrically with depth.

The first cell is chosen from the shortest time the scene resolves (one sample period): the diffusion length
√(a·t_min) must span several cells, so that the surface temperature is right from the first sample on.
"""

from __future__ import annotations

import math

import numpy as np


def first_cell_m(diffusivity_m2_s: float, t_min_s: float, cells_per_length: float = 4.0) -> float:
    """Width of the first cell so that √(a·t_min) spans ``cells_per_length`` cells, m."""
    return math.sqrt(diffusivity_m2_s * t_min_s) / cells_per_length


def graded_widths(thickness_m: float, dx0_m: float, ratio: float = 1.3) -> np.ndarray:
    """Cell widths (m) from the face inwards: dx0, dx0·r, dx0·r², ... summing exactly to ``thickness_m``.

    The last cell absorbs the remainder (merged into its neighbour when the remainder is under half a cell).
    """
    if not thickness_m > 0 or not dx0_m > 0 or not ratio >= 1.0:
        raise ValueError(
            f"graded_widths: need thickness > 0, dx0 > 0, ratio >= 1 (got {thickness_m}, {dx0_m}, {ratio})"
        )
    if dx0_m >= thickness_m:
        return np.array([thickness_m])
    widths = []
    total, w = 0.0, dx0_m
    while total + w < thickness_m:
        widths.append(w)
        total += w
        w *= ratio
    rem = thickness_m - total
    if widths and rem < 0.5 * widths[-1]:
        widths[-1] += rem
    else:
        widths.append(rem)
    return np.array(widths)


def symmetric_graded_widths(thickness_m: float, dx0_m: float, ratio: float = 1.3) -> np.ndarray:
    """Odd number of cells, graded from BOTH faces towards a centre cell whose centre is the mid-plane.

    Used for the flux sensor: fine cells at both faces (contact transients), a node at the thermocouple.
    """
    half = graded_widths(thickness_m / 2.0, dx0_m, ratio)
    if len(half) == 1:
        return np.array([thickness_m])
    centre = 2.0 * half[-1]
    return np.concatenate([half[:-1], [centre], half[:-1][::-1]])
