"""Least squares with two or three parameters, cheap enough for one control cycle (pure).

The material fit (telethermo.control.material_id) solves a 3-parameter least-squares problem per model form
and per noise realisation, one per control cycle. Its columns differ by many orders of magnitude (J per
°C·s^½ against J per W·s^½), so the normal matrix XᵀX is badly scaled: its condition number says more about
the units than about collinearity, and a general solver's result moves in the third digit with the
algorithm. Here the columns are first scaled to unit length (Jacobi scaling, an exact change of units), the
scaled normal matrix (1 on its diagonal, a correlation matrix) is inverted by cofactors in Python floats,
and its 1-norm condition number (within a factor 3 of the 2-norm one) says whether the columns are
collinear. A handful of numpy calls and a few dozen float operations: about a fifth of numpy's
``cond`` + ``inv`` on this size, with better accuracy.
"""

from __future__ import annotations

import numpy as np

#: the largest 1-norm condition number of the scaled normal matrix accepted: columns closer to collinear
#: than about 1e-6 rad carry no separate information at double precision
COND_MAX = 1e12


class NormalEquations:
    """The scaled normal equations of y ≈ X·θ, X with up to three columns; :meth:`solve` uses the first
    ``cols`` of them. ``None`` from :meth:`solve`: singular, non-finite or collinear beyond ``COND_MAX``."""

    __slots__ = ("ok", "_d", "_g", "_c")

    def __init__(self, X: np.ndarray, y: np.ndarray) -> None:
        d = np.sqrt(np.einsum("ij,ij->j", X, X))
        self.ok = bool(np.isfinite(d).all() and (d > 0).all() and np.isfinite(y).all())
        if not self.ok:
            return
        Xs = X / d
        self._d: list[float] = d.tolist()
        self._g: list[list[float]] = (Xs.T @ Xs).tolist()
        self._c: list[float] = (Xs.T @ y).tolist()

    def solve(self, cols: int) -> tuple[list[float], list[list[float]]] | None:
        """(θ, (XᵀX)⁻¹) of the first ``cols`` (2 or 3) columns, in the original units, or None."""
        if not self.ok:
            return None
        inv = _inverse(self._g, cols)
        if inv is None:
            return None
        d, c = self._d, self._c
        theta = [sum(inv[i][j] * c[j] for j in range(cols)) / d[i] for i in range(cols)]
        cov = [[inv[i][j] / (d[i] * d[j]) for j in range(cols)] for i in range(cols)]
        return theta, cov


def _inverse(g: list[list[float]], cols: int) -> list[list[float]] | None:
    """Inverse of the leading ``cols`` × ``cols`` block of the symmetric matrix g by cofactors, or None when
    it is singular or its 1-norm condition number exceeds ``COND_MAX``."""
    if cols == 2:
        a, b, d = g[0][0], g[0][1], g[1][1]
        det = a * d - b * b
        if not det > 0:
            return None
        inv = [[d / det, -b / det], [-b / det, a / det]]
    elif cols == 3:
        a, b, c = g[0][0], g[0][1], g[0][2]
        e, f, i = g[1][1], g[1][2], g[2][2]
        A, B, C = e * i - f * f, c * f - b * i, b * f - c * e
        det = a * A + b * B + c * C
        if not det > 0:
            return None
        E, F, I_ = a * i - c * c, b * c - a * f, a * e - b * b
        inv = [[A / det, B / det, C / det], [B / det, E / det, F / det], [C / det, F / det, I_ / det]]
    else:
        raise ValueError(f"cols must be 2 or 3, not {cols}")
    norm = max(sum(abs(x) for x in row[:cols]) for row in g[:cols])
    norm_inv = max(sum(abs(x) for x in row) for row in inv)
    return inv if norm * norm_inv <= COND_MAX else None
