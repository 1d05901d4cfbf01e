"""Bodies of the 1D chain as finite-volume segments: lumps, slabs, the flux sensor, the finger.

A :class:`Segment` is a run of cells along the heat path, described by what the assembly needs: heat
capacities, conductances between neighbouring cell centres, half-cell conductances to its two faces, and
per-cell perfusion conductances to blood (Pennes). Positions are depths from the segment's front face
(the face towards the pad / the contact).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from telethermo.sim.grid import first_cell_m, graded_widths, symmetric_graded_widths
from telethermo.sim.materials import Material, material

# Blood (benali-khoudja eq. 3: conducto-convective exchange with blood; Pennes perfusion term)
RHO_C_BLOOD_J_m3K = 1060.0 * 3770.0


@dataclass(frozen=True)
class Segment:
    """A run of finite-volume cells (or one lump).

    Attributes:
        name: label (for reports).
        C_J_K: heat capacity per cell, J/K.
        G_int_W_K: conductance between consecutive cell centres (len n−1), W/K.
        G_front_W_K: centre of the first cell to the front face, W/K (inf for a lump).
        G_back_W_K: centre of the last cell to the back face, W/K (inf for a lump).
        G_perf_W_K: per-cell conductance to blood at T_blood_C (perfusion), W/K.
        x_m: depth of each cell centre from the front face, m.
        T_blood_C: arterial blood temperature, °C.
    """

    name: str
    C_J_K: np.ndarray
    G_int_W_K: np.ndarray
    G_front_W_K: float
    G_back_W_K: float
    G_perf_W_K: np.ndarray
    x_m: np.ndarray
    T_blood_C: float = 37.0

    @property
    def n(self) -> int:
        return len(self.C_J_K)


def lump(name: str, C_J_K: float) -> Segment:
    """A single isothermal node (heat sink, TEM plate, or a low-Biot object)."""
    return Segment(name, np.array([float(C_J_K)]), np.zeros(0), math.inf, math.inf, np.zeros(1), np.zeros(1))


def layered(
    name: str,
    layers: list[tuple[Material, float, float]],
    area_m2: float,
    widths_per_layer: list[np.ndarray],
    T_blood_C: float = 37.0,
) -> Segment:
    """Segment from layers (material, thickness m, perfusion 1/s) with the given cell widths per layer."""
    lam, rc, w, om = [], [], [], []
    for (mat, _thk, perf), ws in zip(layers, widths_per_layer):
        lam += [mat.lambda_W_mK] * len(ws)
        rc += [mat.rho_c_J_m3K] * len(ws)
        om += [perf] * len(ws)
        w += list(ws)
    lam, rc, w, om = map(np.asarray, (lam, rc, w, om))
    half_R = w / (2.0 * lam * area_m2)  # K/W, centre to face
    G_int = 1.0 / (half_R[:-1] + half_R[1:])
    x = np.cumsum(w) - w / 2.0
    return Segment(
        name,
        rc * w * area_m2,
        G_int,
        1.0 / half_R[0],
        1.0 / half_R[-1],
        om * RHO_C_BLOOD_J_m3K * w * area_m2,
        x,
        T_blood_C,
    )


def graded_layer_widths(
    layers: list[tuple[Material, float, float]],
    t_min_s: float,
    ratio: float = 1.3,
    cells_per_length: float = 4.0,
) -> list[np.ndarray]:
    """Cell widths per layer, graded from the front face and continuing the growth across layer boundaries."""
    out = []
    dx = first_cell_m(layers[0][0].diffusivity_m2_s, t_min_s, cells_per_length)
    for mat, thk, _ in layers:
        dx = min(dx, first_cell_m(mat.diffusivity_m2_s, t_min_s, cells_per_length) * 8.0, thk)
        ws = graded_widths(thk, dx, ratio)
        out.append(ws)
        dx = ws[-1] * ratio if len(ws) > 1 else ws[-1]
    return out


def slab(
    name: str,
    mat: Material,
    thickness_m: float,
    area_m2: float,
    t_min_s: float,
    ratio: float = 1.3,
    cells_per_length: float = 4.0,
) -> Segment:
    """A homogeneous slab graded from its front (contact) face."""
    layers = [(mat, thickness_m, 0.0)]
    return layered(name, layers, area_m2, graded_layer_widths(layers, t_min_s, ratio, cells_per_length))


def uniform(name: str, mat: Material, thickness_m: float, area_m2: float, cells: int) -> Segment:
    """A homogeneous slab with ``cells`` equal cells."""
    layers = [(mat, thickness_m, 0.0)]
    return layered(name, layers, area_m2, [np.full(cells, thickness_m / cells)])


def sensor_segment(
    name: str,
    mat: Material,
    thickness_m: float,
    area_m2: float,
    t_min_s: float,
    ratio: float = 1.3,
    cells_per_length: float = 4.0,
    cells: int = 0,
) -> Segment:
    """The flux sensor: ``cells`` equal cells (odd), or (cells = 0) graded from both faces with the same
    diffusion scaling as the bodies it touches, so that a make/break is right from its first instant."""
    if cells:
        return uniform(name, mat, thickness_m, area_m2, cells)
    ws = symmetric_graded_widths(
        thickness_m, first_cell_m(mat.diffusivity_m2_s, t_min_s, cells_per_length), ratio
    )
    return layered(name, [(mat, thickness_m, 0.0)], area_m2, [ws])


@dataclass(frozen=True)
class FingerParams:
    """The operator's fingertip pad: skin layers with Pennes perfusion over a core at blood temperature.

    ``layers``: (material name, thickness m, perfusion rate ω 1/s) from the surface inwards; the back face of
    the last layer is held at ``core_C`` (bone / well-perfused core). The perfusion source of a cell is
    ω·ρ_b·c_b·(T_blood − T) per unit volume (Pennes; benali-khoudja eq. 2–5).
    """

    layers: tuple[tuple[str, float, float], ...] = (
        ("skin", 0.6e-3, 0.0),  # epidermis (avascular), fingertip pad
        ("dermis", 1.5e-3, 1.0e-3),
        ("subcutaneous", 6.0e-3, 0.5e-3),
    )
    T_blood_C: float = 37.0
    core_C: float = 37.0

    def material_layers(self) -> list[tuple[Material, float, float]]:
        return [(material(m), float(t), float(w)) for m, t, w in self.layers]

    @property
    def surface_material(self) -> Material:
        return material(self.layers[0][0])

    @property
    def thickness_m(self) -> float:
        return sum(t for _, t, _ in self.layers)


def finger_segment(
    p: FingerParams, area_m2: float, t_min_s: float, ratio: float = 1.3, cells_per_length: float = 4.0
) -> Segment:
    """The finger as a graded, layered, perfused segment (front face = the skin surface)."""
    layers = p.material_layers()
    return layered(
        "finger",
        layers,
        area_m2,
        graded_layer_widths(layers, t_min_s, ratio, cells_per_length),
        T_blood_C=p.T_blood_C,
    )
