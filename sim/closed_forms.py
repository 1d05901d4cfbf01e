"""Closed-form solutions the simulator is checked against (pure functions, SI units, °C)."""

from __future__ import annotations

import math

from scipy.special import erfcx


def contact_temperature_C(b1: float, T1_C: float, b2: float, T2_C: float) -> float:
    """Two semi-infinite bodies in perfect contact: T_c = (b1·T1 + b2·T2)/(b1 + b2) for all t > 0
    (yamamoto eq. 1; guiatni §4.1)."""
    return (b1 * T1_C + b2 * T2_C) / (b1 + b2)


def surface_temperatures_finite_h_C(
    b1: float, T1_C: float, b2: float, T2_C: float, h_W_m2K: float, t_s: float
) -> tuple[float, float]:
    """Two semi-infinite bodies joined by a contact conductance h (Carslaw & Jaeger, Conduction of Heat in
    Solids, 2nd ed., §2.15-type solution via Laplace transform): with k = h·(1/b1 + 1/b2),

        T_s1(t) = T1 − (T1 − T2)·b2/(b1 + b2)·[1 − e^{k²t}·erfc(k√t)]
        T_s2(t) = T2 + (T1 − T2)·b1/(b1 + b2)·[1 − e^{k²t}·erfc(k√t)]

    → T1, T2 at t = 0 and → T_c as t → ∞."""
    k = h_W_m2K * (1.0 / b1 + 1.0 / b2)
    g = 1.0 - float(erfcx(k * math.sqrt(t_s)))
    d = T1_C - T2_C
    return T1_C - d * b2 / (b1 + b2) * g, T2_C + d * b1 / (b1 + b2) * g


def semi_infinite_flux_W_m2(b1: float, T1_C: float, b2: float, T2_C: float, t_s: float) -> float:
    """Heat flux from body 1 into body 2 in perfect contact, W/m²: (T1 − T2)·b1·b2/((b1 + b2)·√(π·t))."""
    return (T1_C - T2_C) * b1 * b2 / ((b1 + b2) * math.sqrt(math.pi * t_s))


def slab_surface_constant_flux_C(
    q_W_m2: float,
    lambda_W_mK: float,
    rho_c_J_m3K: float,
    L_m: float,
    t_s: float,
    T0_C: float = 0.0,
    n_terms: int = 200,
) -> float:
    """Front-face temperature of a slab (thickness L, insulated back, uniform T0) heated from t = 0 by a
    constant flux q at its front (Carslaw & Jaeger, Conduction of Heat in Solids, 2nd ed., §3.3):

        T(0, t) = T0 + q·t/(ρc·L) + (q·L/λ)·[1/3 − (2/π²)·Σ_{n≥1} exp(−n²π²·a·t/L²)/n²],  a = λ/(ρc)
    """
    a = lambda_W_mK / rho_c_J_m3K
    s = sum(math.exp(-((n * math.pi) ** 2) * a * t_s / L_m**2) / n**2 for n in range(1, n_terms + 1))
    return (
        T0_C
        + q_W_m2 * t_s / (rho_c_J_m3K * L_m)
        + q_W_m2 * L_m / lambda_W_mK * (1.0 / 3.0 - 2.0 / math.pi**2 * s)
    )


def semi_infinite_surface_constant_flux_C(q_W_m2: float, b: float, t_s: float, T0_C: float = 0.0) -> float:
    """Surface of a semi-infinite body heated by a constant flux q from t = 0: T0 + 2q·√(t/π)/b."""
    return T0_C + 2.0 * q_W_m2 * math.sqrt(t_s / math.pi) / b
