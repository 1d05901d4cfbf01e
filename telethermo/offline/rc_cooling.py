"""benali-khoudja's cooling experiment on the simulator: τ = R·C per material, thickness, back and load.

"We use a method that increases the temperature of each material part (we can fix this temperature to
40 °C) and monitor the temperature variation graph during the cooling phase" (§4, Table 1: with no load
and with a 50 g load). Here: the object (and its load) at 40 °C meets the simulator's finger (at its
steady state in the scene's air) with 6 N at t = 0; the contact face is sampled every 0.1 s for 60 s and
the exponential T_inf + (T_0 − T_inf)·exp(−t/τ) is fitted from 0.5 s on (after the first instant, which
eq. 1 renders). The load is a 50 g brass weight (19 J/K) on the object's back through the contact law at
its own weight (0.49 N). φ = (T_inf − T_finger0)/(T_object0 − T_finger0) goes with τ.

``python -m bench.rc_identify`` runs :func:`identify` over the table and writes
telethermo/data/render_rc.toml, which the render mode reads (telethermo.control.later_rc); the simulator
is used here only.
"""

from __future__ import annotations

import numpy as np

from telethermo.sim.bodies import lump, slab
from telethermo.sim.chain import ADIABATIC, Boundary, assemble
from telethermo.sim.contact import contact_resistance_m2K_W
from telethermo.sim.expint import Modal
from telethermo.sim.materials import material
from telethermo.sim.pair import reversed_segment
from telethermo.sim.plant import Body, GridSettings
from telethermo.sim.tem import load_rig_params
from telethermo.sim.touch import BodySpec
from telethermo.control.later_rc import fit_exponential

MATERIALS = (
    "eps",
    "oak",
    "pvc",
    "glass",
    "ceramic",
    "stainless_steel",
    "carbon_steel",
    "brass",
    "aluminium",
    "copper",
)
THICKNESSES_MM = (1.0, 2.0, 5.0, 10.0, 20.0)
LOAD_G = 50.0
LOAD_C_J_PER_KG_K = 380.0  # brass weight
T_HOT_C = 40.0
FORCE_N = 6.0
AMBIENT_C = 25.0
DURATION_S, SAMPLE_S, FIT_FROM_S = 60.0, 0.1, 0.5


def cooling_curve(
    mat_name: str,
    thickness_mm: float,
    *,
    load_g: float = 0.0,
    back: str = "adiabatic",
    duration_s: float = DURATION_S,
    sample_s: float = SAMPLE_S,
    grid: GridSettings | None = None,
) -> tuple[np.ndarray, np.ndarray, float]:
    """The object's contact face while it cools on the finger: (t s, T °C, the finger's initial skin °C)."""
    params = load_rig_params()
    A = params.area_m2
    grid = grid or GridSettings(t_min_s=0.01)
    finger = Body(BodySpec("finger", kind="finger"), A, AMBIENT_C, params.h_air_W_m2K, grid)
    T_f0 = finger.surface_C()
    obj = slab(
        "object", material(mat_name), thickness_mm * 1e-3, A, grid.t_min_s, grid.ratio, grid.cells_per_length
    )
    R_f = contact_resistance_m2K_W(FORCE_N, params.R_at_1N_m2K_W, params.force_exponent) / A
    segs, links = [reversed_segment(finger.segment), obj], [R_f]
    if load_g > 0:
        segs.append(lump("load", load_g * 1e-3 * LOAD_C_J_PER_KG_K))
        F_load = load_g * 1e-3 * 9.81
        links.append(contact_resistance_m2K_W(F_load, params.R_at_1N_m2K_W, params.force_exponent) / A)
    back_b = Boundary(params.h_air_W_m2K * A, AMBIENT_C) if back == "ambient" else ADIABATIC
    system = assemble(segs, links, finger.back, back_b)
    x = np.concatenate([finger.x[: finger.n][::-1], np.full(system.n - finger.n, T_HOT_C), [0.0]])
    Phi, c, _, _ = Modal(system).step_matrices(sample_s)
    f, f0 = system.face_functional(1, "front")
    n = int(round(duration_s / sample_s))
    T = np.empty(n + 1)
    T[0] = T_HOT_C
    for k in range(1, n + 1):
        x = Phi @ x + c
        T[k] = float(f @ x[: system.n] + f0)
    return np.arange(n + 1) * sample_s, T, T_f0


def identify(mat_name: str, thickness_mm: float, *, load_g: float = 0.0, back: str = "adiabatic") -> dict:
    """τ, φ and the fit's RMS of one object (see module docstring)."""
    t, T, T_f0 = cooling_curve(mat_name, thickness_mm, load_g=load_g, back=back)
    m = t >= FIT_FROM_S
    tau, T_inf, _T0, rms = fit_exponential(t[m], T[m])
    return {
        "material": mat_name,
        "thickness_mm": thickness_mm,
        "back": back,
        "load_g": load_g,
        "tau_s": round(tau, 4),
        "final_fraction": round((T_inf - T_f0) / (T_HOT_C - T_f0), 5),
        "fit_rms_C": round(rms, 4),
    }
