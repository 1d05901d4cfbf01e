"""A virtual finger on the probe (experiment, off by default; docs/control.md "A virtual finger on the
probe"): while the probe touches an object, its setpoint is the surface temperature of a semi-infinite skin
that loses the heat the probe's own sensor measures flowing into the object, instead of the master's finger
estimate. The object then exchanges heat with something that behaves like a finger even when the display,
at its current or ramp limit, cannot pull the operator's finger where the object would.

The skin is the deep slab of :mod:`telethermo.control.later_conduction` (graded finite volumes, exact step for
a flux held over the period) made of a material of effusivity ``b`` W·s^½/(m²·K) (λ fixed at
:data:`LAMBDA_W_MK`, ρc = b²/λ), uniform at the finger's temperature when the touch starts:

    model = vf_model(b=1100.0, area_m2=2.25e-4, dt_s=0.01)
    st = vf_start(model, T_finger0_C=33.6)
    st, T_skin_C = vf_step(model, st, Q_out_W)    # Q_out_W: heat leaving the probe into the object, W
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from telethermo.control.later_conduction import RATIO, Slab, build_slab, graded_widths
from telethermo.control.virtual_object import ObjectMaterial

#: the virtual skin's conductivity, W/(m·K) (dermis; with b it sets ρc = b²/λ)
LAMBDA_W_MK = 0.37
#: the probe's contact area, m²: the default 15 × 15 mm flux sensor (as telethermo.control.later_conduction)
VF_AREA_M2 = 0.015 * 0.015
#: the skin is this deep: 4 diffusion lengths of a minute, far beyond a touch
HORIZON_S = 60.0
#: first cell resolves this time, s (as the render's later-phase model)
T_FIRST_S = 0.1


@dataclass(frozen=True, eq=False)
class VirtualFinger:
    """The virtual skin's slab (stepped every ``slab.dt_s`` s) and its effusivity b, W·s^½/(m²·K)."""

    slab: Slab
    b: float


def vf_model(b: float, area_m2: float, dt_s: float) -> VirtualFinger:
    """The virtual finger of effusivity ``b`` over ``area_m2`` (the probe's contact area, m²), stepped every
    ``dt_s`` s."""
    for name, v in (("b", b), ("area_m2", area_m2), ("dt_s", dt_s)):
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"vf_model: {name} must be a finite number > 0, got {v!r}")
    mat = ObjectMaterial("virtual finger", LAMBDA_W_MK, b * b / LAMBDA_W_MK)
    a = mat.diffusivity_m2_s
    depth = 4.0 * math.sqrt(a * HORIZON_S)
    widths = graded_widths(0.5 * math.sqrt(a * T_FIRST_S), RATIO, depth)
    return VirtualFinger(build_slab(mat, widths, area_m2, dt_s), float(b))


def vf_start(model: VirtualFinger, T_finger0_C: float) -> np.ndarray:
    """The skin's cells at the touch's start: uniform at the finger's temperature, °C."""
    return np.full(len(model.slab.widths_m), float(T_finger0_C))


def vf_step(model: VirtualFinger, x: np.ndarray, Q_out_W: float) -> tuple[np.ndarray, float]:
    """One period with ``Q_out_W`` (W) leaving the skin into the object: the new cells and the skin's surface
    temperature, °C. A non-finite flux counts as 0 W (the envelope trips on it elsewhere)."""
    q_in = -float(Q_out_W) if math.isfinite(Q_out_W) else 0.0
    s = model.slab
    x_new = s.Phi @ x + s.gam_q * q_in + s.gam_s
    return x_new, s.surface_C(x_new, q_in)


def vf_step_held(model: VirtualFinger, x: np.ndarray, T_surface_C: float) -> tuple[np.ndarray, float]:
    """One period with the skin's surface held at ``T_surface_C`` (°C; the admittance form: the probe's face
    temperature in, the finger's heat out): the new cells and the heat that entered the skin over the period,
    W (> 0 when the object heats the finger). A non-finite temperature counts as no heat (0 W)."""
    s = model.slab
    free = s.Phi @ x + s.gam_s
    if not math.isfinite(T_surface_C):
        return free, 0.0
    q_in = (float(T_surface_C) - float(free[0])) / (float(s.gam_q[0]) + 1.0 / s.G_front_W_K)
    return free + s.gam_q * q_in, q_in
