"""Two bodies pressed together (no rig): the building block of the closed-form checks.

Body A's front face touches body B's front face through a contact resistance R'' (m²·K/W; 0 = perfect).
Both are graded slabs (or any segments) with their own back boundaries; integrated exactly (sim.expint).
"""

from __future__ import annotations

import numpy as np

from telethermo.sim.bodies import Segment
from telethermo.sim.chain import ADIABATIC, Boundary, assemble
from telethermo.sim.expint import Modal


def reversed_segment(sg: Segment) -> Segment:
    """The same segment seen from its back face (so its front face becomes the chain's downstream end)."""
    return Segment(
        sg.name,
        sg.C_J_K[::-1].copy(),
        sg.G_int_W_K[::-1].copy(),
        sg.G_back_W_K,
        sg.G_front_W_K,
        sg.G_perf_W_K[::-1].copy(),
        sg.x_m[::-1].copy(),
        sg.T_blood_C,
    )


class ContactPair:
    """A (front face) against B (front face), starting from given cell temperatures at t = 0.

    Attributes: t_s, and the properties T_surface_A_C, T_surface_B_C, Q_AB_W (heat from A into B, W).
    """

    def __init__(
        self,
        a: Segment,
        xa_C: np.ndarray | float,
        b: Segment,
        xb_C: np.ndarray | float,
        area_m2: float,
        R_contact_m2K_W: float = 0.0,
        back_a: Boundary = ADIABATIC,
        back_b: Boundary = ADIABATIC,
    ) -> None:
        self.system = assemble([reversed_segment(a), b], [R_contact_m2K_W / area_m2], back_a, back_b)
        self.na = a.n
        xa = np.broadcast_to(np.asarray(xa_C, dtype=float), (a.n,))[::-1]
        xb = np.broadcast_to(np.asarray(xb_C, dtype=float), (b.n,))
        self.x = np.concatenate([xa, xb, [0.0]])
        self.modal = Modal(self.system)
        self._fa = self.system.face_functional(0, "back")
        self._fb = self.system.face_functional(1, "front")
        self._q = self.system.link_flux_functional(0)
        self.t_s = 0.0
        self._stored0 = self.system.stored_J(self.x)

    def advance(self, dt_s: float) -> None:
        Phi, c, _, _ = self.modal.step_matrices(dt_s)
        self.x = Phi @ self.x + c
        self.t_s += dt_s

    def _eval(self, fc) -> float:
        f, f0 = fc
        return float(f @ self.x[: self.system.n] + f0)

    @property
    def T_surface_A_C(self) -> float:
        return self._eval(self._fa)

    @property
    def T_surface_B_C(self) -> float:
        return self._eval(self._fb)

    @property
    def Q_AB_W(self) -> float:
        return self._eval(self._q)

    def energy_residual_J(self) -> float:
        """Stored-energy change plus heat that left to reservoirs (0 for a conservative scheme), J."""
        return self.system.stored_J(self.x) - self._stored0 + float(self.x[-1])
