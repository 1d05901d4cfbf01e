"""Exact exponential integration of the chain for one step (modal form), with energy bookkeeping.

For C·dx/dt = K·x + s + E·u(t), with u linear over the step (first-order hold between u_n and u_{n+1}):
z = C^½·x makes the system symmetric, M = C^-½·K·C^-½ = V·Λ·Vᵀ, and each mode is integrated exactly with the
φ-functions φ1(z) = (e^z − 1)/z, φ2 = (e^z − 1 − z)/z², φ3 = (e^z − 1 − z − z²/2)/z³. Stiffness (µm skin
cells, metal slabs) costs nothing: there is no stability limit and no time-discretisation error for the
conduction; the only approximation is the hold on u (the TEM plate heats, which depend weakly on the plate
temperatures through α·I·T and are solved implicitly, 2×2, at the end of the step).

The step matrices act on the augmented state [x, E_out], where E_out (J) accumulates the heat that left the
system to reservoirs, integrated exactly from the same modal solution.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import eigh

from telethermo.sim.chain import System


def _phis(z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """e^z, φ1, φ2, φ3 elementwise, accurate for z → 0 and z → −∞."""
    z = np.asarray(z, dtype=float)
    e = np.exp(z)
    small = np.abs(z) < 0.05
    zs = np.where(small, 1.0, z)
    em1 = np.expm1(zs)
    p1 = np.where(small, 1 + z / 2 + z**2 / 6 + z**3 / 24 + z**4 / 120, em1 / zs)
    p2 = np.where(small, 0.5 + z / 6 + z**2 / 24 + z**3 / 120 + z**4 / 720, (em1 - zs) / zs**2)
    p3 = np.where(
        small, 1 / 6 + z / 24 + z**2 / 120 + z**3 / 720 + z**4 / 5040, (em1 - zs - zs**2 / 2) / zs**3
    )
    return e, p1, p2, p3


class Modal:
    """Eigen-decomposition of one assembled system; builds step matrices for any dt."""

    def __init__(self, system: System, input_cells: tuple[int, ...] = ()) -> None:
        self.system = system
        self.input_cells = tuple(input_cells)
        C = system.C
        self.rc = np.sqrt(C)
        M = system.K / np.outer(self.rc, self.rc)
        M = 0.5 * (M + M.T)
        self.lam, self.V = eigh(M)
        self.lam = np.minimum(self.lam, 0.0)  # K is negative semi-definite: clip round-off
        self.f, self.f0 = system.heat_out_functional()
        n = system.n
        E = np.zeros((n, len(self.input_cells)))
        for j, i in enumerate(self.input_cells):
            E[i, j] = 1.0
        # in z-coordinates the forcing is C^-½ (s + E u)
        self.Vt_s = self.V.T @ (system.s / self.rc)
        self.Vt_E = self.V.T @ (E / self.rc[:, None])
        self.left = self.V / self.rc[:, None] * 1.0  # x = C^-½ V y
        self.right = self.V.T * self.rc[None, :]  # y = Vᵀ C^½ x
        self.fL = self.f @ self.left  # heat-out rate = fL·y + f0

    def step_matrices(self, dt_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(Phi, c, B0, B1) on the augmented state [x, E_out]: x' = Phi·x + c + B0·u_n + B1·u_{n+1}."""
        n = self.system.n
        e, p1, p2, p3 = _phis(self.lam * dt_s)
        L, R = self.left, self.right
        m = n + 1
        Phi = np.zeros((m, m))
        Phi[:n, :n] = (L * e) @ R
        Phi[n, :n] = (self.fL * dt_s * p1) @ R
        Phi[n, n] = 1.0
        c = np.zeros(m)
        c[:n] = L @ (dt_s * p1 * self.Vt_s)
        c[n] = self.fL @ (dt_s**2 * p2 * self.Vt_s) + self.f0 * dt_s
        k = len(self.input_cells)
        G0 = np.zeros((m, k))
        G1 = np.zeros((m, k))
        if k:
            # u(t) = u_n + (u_{n+1} − u_n)·t/dt  ->  weights of u_n and u_{n+1}
            a1 = (dt_s * p1)[:, None] * self.Vt_E
            a2 = (dt_s * p2)[:, None] * self.Vt_E
            G0[:n] = L @ (a1 - a2)
            G1[:n] = L @ a2
            b2 = (dt_s**2 * p2)[:, None] * self.Vt_E
            b3 = (dt_s**2 * p3)[:, None] * self.Vt_E
            G0[n] = self.fL @ (b2 - b3)
            G1[n] = self.fL @ b3
        return Phi, c, G0, G1
