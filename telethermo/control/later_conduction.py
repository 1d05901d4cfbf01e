"""Later-phase rendering by a small real-time conduction model of the virtual object (1-D finite volumes).

The object is a slab of a few graded cells (the first ones thin, growing towards the back) with its back
condition (adiabatic, or loss to ambient air), driven every cycle by the heat flux the finger sends into
the pad: the pad's own flux sensor measures it at its mid-plane (``-Q_W``). Optionally the heat stored on
the way in the sensor's upper half is added back (``C_front_J_K`` times the rate of the pad's surface
estimate; measured by bench/rendering_bench.py: better on Al 1 mm, worse on glass, steel and EPS, so off
by default). A few cells cannot resolve the first instant of a
contact (the flux is singular at t = 0+), which eq. 1 renders exactly. So the model renders

    T_render(t) = T_contact (eq. 1) + [T_s,slab(t) - T_s,deep(t)]

where ``deep`` is the same grid continued far deeper than heat travels during a touch (a semi-infinite
twin, adiabatic at its end): both see the same flux, so the front cells' discretisation error cancels and
the bracket is what the object's finite thickness and its back add (0 until heat reaches the back). For a
thick object the bracket stays ~0 and the model renders eq. 1, as the semi-infinite model does.

Each slab is integrated exactly over the control period for a flux held over it (matrix exponential,
computed once when the model is built): pure, stable for any period, a few multiply-adds per cycle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from telethermo.control.virtual_object import H_AIR_W_M2K, ObjectMaterial, VirtualObject

#: the deep twin reaches 4 diffusion lengths of this time, s (longer than any touch it renders)
HORIZON_S = 60.0
#: heat capacity between the flux sensor's mid-plane and the pad's surface, J/K: half of the default
#: 0.42 mm, 15 × 15 mm sensor (ρc = 2.0e6 J/(m³·K), the design value of telethermo.control.core's R_sensor)
C_FRONT_J_K = 0.5 * 0.42e-3 * 0.015 * 0.015 * 2.0e6
#: first cell = √(a·T_FIRST_S)/2, geometric growth RATIO, at most MAX_CELLS per slab
T_FIRST_S = 0.1
RATIO = 1.5
MAX_CELLS = 24


def graded_widths(first_m: float, ratio: float, depth_m: float, max_cells: int = MAX_CELLS) -> np.ndarray:
    """Cell widths from the front: first_m·ratio^k until ``depth_m`` is filled (last cell trimmed, a thin
    remainder merged into its neighbour), m. Uniform cells if ``max_cells`` would be exceeded."""
    w: list[float] = []
    total, dx = 0.0, first_m
    while total < depth_m * (1 - 1e-12):
        dx_k = min(dx, depth_m - total)
        w.append(dx_k)
        total += dx_k
        dx *= ratio
    if len(w) > 1 and w[-1] < 0.3 * w[-2]:
        w[-2] += w.pop()
    if len(w) > max_cells:
        return np.full(max_cells, depth_m / max_cells)
    return np.asarray(w)


@dataclass(frozen=True, eq=False)
class Slab:
    """One slab integrated over ``dt_s``: x' = Phi·x + gam_q·q_in_W + gam_s (cell temperatures, °C).

    Attributes:
        widths_m: cell widths, m. G_front_W_K: first cell centre to the front face, W/K.
        Phi, gam_q, gam_s: exact step for a flux held over the step. dt_s: the step, s.
    """

    widths_m: np.ndarray
    G_front_W_K: float
    Phi: np.ndarray
    gam_q: np.ndarray
    gam_s: np.ndarray
    dt_s: float

    def surface_C(self, x: np.ndarray, q_in_W: float) -> float:
        """Front-face temperature with ``q_in_W`` entering it, °C."""
        return float(x[0] + q_in_W / self.G_front_W_K)


def build_slab(
    mat: ObjectMaterial,
    widths_m: np.ndarray,
    area_m2: float,
    dt_s: float,
    *,
    G_back_W_K: float = 0.0,
    T_back_C: float = 0.0,
) -> Slab:
    """A slab of ``mat`` with the given cells, heated at its front, losing G_back·(T − T_back) at its back."""
    w = np.asarray(widths_m, float)
    n = len(w)
    half_R = w / (2.0 * mat.lambda_W_mK * area_m2)  # centre to face, K/W
    C = mat.rho_c_J_m3K * w * area_m2
    K = np.zeros((n, n))
    for i in range(n - 1):
        g = 1.0 / (half_R[i] + half_R[i + 1])
        K[i, i] -= g
        K[i + 1, i + 1] -= g
        K[i, i + 1] += g
        K[i + 1, i] += g
    s = np.zeros(n)
    if G_back_W_K > 0:
        g = 1.0 / (half_R[-1] + 1.0 / G_back_W_K)
        K[-1, -1] -= g
        s[-1] = g * T_back_C
    # augmented exponential: d/dt [x, q, 1] = [[A, e0/C, s/C], 0, 0]
    M = np.zeros((n + 2, n + 2))
    M[:n, :n] = K / C[:, None]
    M[0, n] = 1.0 / C[0]
    M[:n, n + 1] = s / C
    E = expm(M * dt_s)
    return Slab(w, 1.0 / half_R[0], E[:n, :n], E[:n, n].copy(), E[:n, n + 1].copy(), float(dt_s))


@dataclass(frozen=True, eq=False)
class ConductionModel:
    """The virtual object's slab and its deep (semi-infinite) twin, stepped together; ``C_front_J_K``: heat
    capacity between the flux measurement and the pad's surface, J/K."""

    slab: Slab
    deep: Slab
    C_front_J_K: float = 0.0


@dataclass(frozen=True, eq=False)
class ConductionState:
    """Cell temperatures of the slab and of the twin, °C; the pad's last surface estimate, °C."""

    x_slab: np.ndarray
    x_deep: np.ndarray
    T_surface_C: float = math.nan


def conduction_model(
    obj: VirtualObject, mat: ObjectMaterial, dt_s: float, C_front_J_K: float = 0.0
) -> ConductionModel:
    """The model of ``obj`` (made of ``mat``) stepped every ``dt_s`` seconds."""
    if not (math.isfinite(dt_s) and dt_s > 0):
        raise ValueError(f"conduction_model: dt_s must be > 0, got {dt_s!r}")
    L = obj.thickness_mm * 1e-3
    a = mat.diffusivity_m2_s
    first = min(0.5 * math.sqrt(a * T_FIRST_S), L / 4.0)
    depth = max(4.0 * math.sqrt(a * HORIZON_S), 2.0 * L)
    G_back = H_AIR_W_M2K * obj.area_m2 if obj.back == "ambient" else 0.0
    slab = build_slab(
        mat, graded_widths(first, RATIO, L), obj.area_m2, dt_s, G_back_W_K=G_back, T_back_C=obj.T_ambient_C
    )
    deep = build_slab(mat, graded_widths(first, RATIO, depth), obj.area_m2, dt_s)
    return ConductionModel(slab, deep, float(C_front_J_K))


def conduction_start(model: ConductionModel, T_object0_C: float) -> ConductionState:
    """Both slabs uniform at the object's initial temperature (°C) at the touch."""
    return ConductionState(
        np.full(len(model.slab.widths_m), float(T_object0_C)),
        np.full(len(model.deep.widths_m), float(T_object0_C)),
    )


def conduction_step(
    model: ConductionModel, state: ConductionState, q_in_W: float, T_surface_C: float = math.nan
) -> tuple[ConductionState, float]:
    """Advance one period with ``q_in_W`` (W, measured at the sensor's mid-plane) entering the object's
    front and the pad's surface estimate ``T_surface_C`` (°C); returns the new state and the finite-object
    correction T_s,slab − T_s,deep, °C (add it to eq. 1's T_contact)."""
    s, d = model.slab, model.deep
    q = float(q_in_W) if math.isfinite(q_in_W) else 0.0
    if math.isfinite(T_surface_C) and math.isfinite(state.T_surface_C):
        q += model.C_front_J_K * (T_surface_C - state.T_surface_C) / s.dt_s
    xs = s.Phi @ state.x_slab + s.gam_q * q + s.gam_s
    xd = d.Phi @ state.x_deep + d.gam_q * q + d.gam_s
    return ConductionState(xs, xd, float(T_surface_C)), s.surface_C(xs, q) - d.surface_C(xd, q)
