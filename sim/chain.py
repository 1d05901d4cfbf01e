"""Assembly of a 1D chain of segments into the linear system C·dT/dt = K·T + s + E·u.

The chain is reservoir — seg0 — link — seg1 — ... — segN — reservoir. Links are series resistances between
neighbouring segments (grease, the TEM pellets, a contact resistance); 0 means perfect contact. K is
tridiagonal (the chain is 1D), symmetric, negative semi-definite. Heat leaves the system only to reservoirs
(ambient, blood, body core), so ``heat_out`` below is the whole external balance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from telethermo.sim.bodies import Segment


@dataclass(frozen=True, slots=True)
class Boundary:
    """An end of the chain: conductance from the end face to a reservoir at T_C (0 = adiabatic,
    inf = Dirichlet)."""

    G_W_K: float
    T_C: float = 0.0


ADIABATIC = Boundary(0.0, 0.0)


def _series(*G: float) -> float:
    R = 0.0
    for g in G:
        if g == 0.0:
            return 0.0
        R += 0.0 if math.isinf(g) else 1.0 / g
    return math.inf if R == 0.0 else 1.0 / R


@dataclass
class System:
    """The assembled chain. ``x`` vectors are cell temperatures, °C, in segment order.

    Attributes:
        C: heat capacity per cell, J/K.
        K: conductance matrix, W/K (tridiagonal; includes reservoir conductances on the diagonal).
        s: constant heat source per cell from reservoirs and perfusion, W.
        offsets: start index of each segment.
        segments, link_R_K_W, front, back: what was assembled.
    """

    C: np.ndarray
    K: np.ndarray
    s: np.ndarray
    offsets: list[int]
    segments: list[Segment]
    link_G_W_K: list[float]
    front: Boundary
    back: Boundary

    @property
    def n(self) -> int:
        return len(self.C)

    def index(self, seg: int, cell: int = 0) -> int:
        """Global index of a cell (negative ``cell`` counts from the segment's back)."""
        n = self.segments[seg].n
        return self.offsets[seg] + (cell % n)

    def heat_out_functional(self) -> tuple[np.ndarray, float]:
        """(f, f0) with the net heat flow out of the system to all reservoirs = f·x + f0, W."""
        return -self.K.sum(axis=0), -float(self.s.sum())

    def stored_J(self, x: np.ndarray) -> float:
        """Σ C·T, J (relative to 0 °C)."""
        return float(self.C @ x[: self.n])

    def link_flux_functional(self, link: int) -> tuple[np.ndarray, float]:
        """Heat flow across link ``link`` (between segment link and link+1), towards the back, W."""
        f = np.zeros(self.n)
        i, j = self.index(link, -1), self.index(link + 1, 0)
        g = self.link_G_W_K[link]
        f[i], f[j] = g, -g
        return f, 0.0

    def face_functional(self, seg: int, side: str) -> tuple[np.ndarray, float]:
        """Temperature of a segment face ('front' or 'back') as a linear functional (f, f0) of x, °C."""
        sg = self.segments[seg]
        f = np.zeros(self.n)
        if side == "back":
            i, G_half = self.index(seg, -1), sg.G_back_W_K
            if seg + 1 < len(self.segments):
                flux, f0 = self.link_flux_functional(seg)
            else:
                g = _series(G_half, self.back.G_W_K)
                flux = np.zeros(self.n)
                flux[i] = g
                f0 = -g * self.back.T_C
            sign = -1.0
        else:
            i, G_half = self.index(seg, 0), sg.G_front_W_K
            if seg > 0:
                flux, f0 = self.link_flux_functional(seg - 1)  # flux into this segment through the front face
            else:
                g = _series(G_half, self.front.G_W_K)
                flux = np.zeros(self.n)
                flux[i] = -g
                f0 = g * self.front.T_C
            sign = 1.0
        f[i] = 1.0
        if math.isinf(G_half):
            return f, 0.0
        # T_face = x_i ∓ flux/G_half (flux leaving through the back face lowers it;
        # entering the front raises it)
        return f + sign * flux / G_half, sign * f0 / G_half

    def steady_state(self, u_W: dict[int, float] | None = None) -> np.ndarray:
        """Steady temperatures with constant extra heat inputs {cell index: W}."""
        rhs = -self.s.copy()
        for i, q in (u_W or {}).items():
            rhs[i] -= q
        return np.linalg.solve(self.K, rhs)


def assemble(segments: list[Segment], link_R_K_W: list[float], front: Boundary, back: Boundary) -> System:
    """Assemble segments joined by series resistances (K/W; 0 = perfect) into a :class:`System`."""
    if len(link_R_K_W) != len(segments) - 1:
        raise ValueError("assemble: need one link resistance between each pair of segments")
    n = sum(sg.n for sg in segments)
    C = np.concatenate([sg.C_J_K for sg in segments])
    K = np.zeros((n, n))
    s = np.zeros(n)
    offsets, link_G = [], []
    o = 0
    for k, sg in enumerate(segments):
        offsets.append(o)
        for i, g in enumerate(sg.G_int_W_K):
            a, b = o + i, o + i + 1
            K[a, a] -= g
            K[b, b] -= g
            K[a, b] += g
            K[b, a] += g
        for i, gp in enumerate(sg.G_perf_W_K):
            if gp:
                K[o + i, o + i] -= gp
                s[o + i] += gp * sg.T_blood_C
        if k + 1 < len(segments):
            nxt = segments[k + 1]
            R = link_R_K_W[k]
            g = _series(sg.G_back_W_K, math.inf if R == 0 else 1.0 / R, nxt.G_front_W_K)
            if math.isinf(g):
                raise ValueError(f"assemble: perfect link between two lumps {sg.name!r} and {nxt.name!r}")
            link_G.append(g)
            a, b = o + sg.n - 1, o + sg.n
            K[a, a] -= g
            K[b, b] -= g
            K[a, b] += g
            K[b, a] += g
        o += sg.n
    for bnd, seg, idx in ((front, segments[0], 0), (back, segments[-1], n - 1)):
        G_half = seg.G_front_W_K if bnd is front else seg.G_back_W_K
        g = _series(G_half, bnd.G_W_K)
        if math.isinf(g):
            raise ValueError("assemble: a lump cannot touch a Dirichlet boundary directly")
        K[idx, idx] -= g
        s[idx] += g * bnd.T_C
    return System(C, K, s, offsets, list(segments), link_G, front, back)
