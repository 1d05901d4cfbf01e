"""The conduction core against closed forms: semi-infinite contact (perfect and finite h), erf profiles."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import erf

from telethermo.sim import bodies as B
from telethermo.sim.closed_forms import (
    contact_temperature_C,
    semi_infinite_flux_W_m2,
    surface_temperatures_finite_h_C,
)
from telethermo.sim.contact import contact_resistance_m2K_W
from telethermo.sim.materials import materials
from telethermo.sim.pair import ContactPair
from telethermo.sim.plant import GridSettings

A_M2 = 2.25e-4
MATS = ["eps", "oak", "glass", "brass", "aluminium", "copper"]
T_FINGER_C = 33.0
T_OBJECTS_C = [10.0, 25.0, 45.0]


def semi_infinite(name: str, grid: GridSettings = GridSettings()) -> B.Segment:
    """A slab of the default grid, deep enough (8·√(a·2 s)) to be semi-infinite for 2 s."""
    m = materials()[name]
    return B.slab(
        name,
        m,
        8.0 * math.sqrt(m.diffusivity_m2_s * 2.0),
        A_M2,
        grid.t_min_s,
        grid.ratio,
        grid.cells_per_length,
    )


def run(pair: ContactPair, t_end: float = 2.0, dt: float = 0.01):
    """Yield pair after each step once t >= 0.05 s."""
    for _ in range(int(round(t_end / dt))):
        pair.advance(dt)
        if pair.t_s >= 0.05 - 1e-9:
            yield pair


@pytest.mark.parametrize("name", MATS)
@pytest.mark.parametrize("T_obj", T_OBJECTS_C)
def test_perfect_contact_surface_temperature_and_flux(name, T_obj):
    skin, mat = materials()["skin"], materials()[name]
    pair = ContactPair(semi_infinite("skin"), T_FINGER_C, semi_infinite(name), T_obj, A_M2, 0.0)
    Tc = contact_temperature_C(skin.b, T_FINGER_C, mat.b, T_obj)
    worst_T = worst_q = 0.0
    for p in run(pair):
        worst_T = max(worst_T, abs(p.T_surface_A_C - Tc), abs(p.T_surface_B_C - Tc))
        q = semi_infinite_flux_W_m2(skin.b, T_FINGER_C, mat.b, T_obj, p.t_s) * A_M2
        worst_q = max(worst_q, abs(p.Q_AB_W - q) / abs(q))
    assert worst_T <= 0.02, f"{name}: surface off the closed form by {worst_T:.4f} °C"
    assert worst_q <= 0.01, f"{name}: flux off the closed form by {100 * worst_q:.2f} %"


@pytest.mark.parametrize("name", MATS)
def test_perfect_contact_with_independent_grids(name):
    """Grids not scaled alike on both sides (so no discrete similarity helps): still within 0.02 °C."""
    skin, mat = materials()["skin"], materials()[name]
    a = semi_infinite("skin", GridSettings(t_min_s=0.01, ratio=1.2, cells_per_length=8.0))
    b = semi_infinite(name, GridSettings(t_min_s=0.004, ratio=1.25, cells_per_length=8.0))
    pair = ContactPair(a, T_FINGER_C, b, 15.0, A_M2, 0.0)
    Tc = contact_temperature_C(skin.b, T_FINGER_C, mat.b, 15.0)
    worst = max(max(abs(p.T_surface_A_C - Tc), abs(p.T_surface_B_C - Tc)) for p in run(pair))
    assert worst <= 0.02


@pytest.mark.parametrize("name", ["oak", "glass", "aluminium"])
def test_interior_profile_is_erf(name):
    skin, mat = materials()["skin"], materials()[name]
    a, b = semi_infinite("skin"), semi_infinite(name)
    pair = ContactPair(a, T_FINGER_C, b, 10.0, A_M2, 0.0)
    for _ in range(50):
        pair.advance(0.01)
    Tc = contact_temperature_C(skin.b, T_FINGER_C, mat.b, 10.0)
    exact = Tc + (10.0 - Tc) * erf(b.x_m / (2.0 * np.sqrt(mat.diffusivity_m2_s * pair.t_s)))
    got = pair.x[a.n : a.n + b.n]
    assert np.max(np.abs(got - exact)) <= 0.05


@pytest.mark.parametrize("name", MATS)
@pytest.mark.parametrize("h", [500.0, 2000.0, 1e4, 5e4])
def test_finite_contact_conductance_matches_carslaw_jaeger(name, h):
    skin, mat = materials()["skin"], materials()[name]
    pair = ContactPair(semi_infinite("skin"), T_FINGER_C, semi_infinite(name), 10.0, A_M2, 1.0 / h)
    worst = 0.0
    for p in run(pair):
        s1, s2 = surface_temperatures_finite_h_C(skin.b, T_FINGER_C, mat.b, 10.0, h, p.t_s)
        worst = max(worst, abs(p.T_surface_A_C - s1), abs(p.T_surface_B_C - s2))
    assert worst <= 0.05, f"{name}, h={h}: {worst:.4f} °C"


def test_finite_h_closed_form_limits():
    """The closed form itself: starts at the initial temperatures, ends at T_c, and h → ∞ gives T_c."""
    b1, b2 = 1000.0, 20000.0
    Tc = contact_temperature_C(b1, 33.0, b2, 10.0)
    s1, s2 = surface_temperatures_finite_h_C(b1, 33.0, b2, 10.0, 100.0, 1e-9)
    assert s1 == pytest.approx(33.0, abs=1e-3) and s2 == pytest.approx(10.0, abs=1e-3)
    s1, s2 = surface_temperatures_finite_h_C(b1, 33.0, b2, 10.0, 1e9, 0.1)
    assert s1 == pytest.approx(Tc, abs=1e-3) and s2 == pytest.approx(Tc, abs=1e-3)


@pytest.mark.parametrize("force_N", [2.0, 8.0, 20.0])
def test_force_law_drives_the_contact(force_N):
    """Contact through the force law equals the closed form with h = 1/R''(F), at 2, 8 and 20 N: the
    conductance keeps rising with force and stays finite (never perfect)."""
    R = contact_resistance_m2K_W(force_N)
    assert R == pytest.approx(5e-4 / force_N**2)
    assert 0.0 < R < math.inf and math.isinf(contact_resistance_m2K_W(0.0))
    forces = np.linspace(0.2, 20.0, 60)
    assert np.all(np.diff([contact_resistance_m2K_W(f) for f in forces]) < 0)  # more force, less resistance
    skin, mat = materials()["skin"], materials()["aluminium"]
    pair = ContactPair(semi_infinite("skin"), 33.0, semi_infinite("aluminium"), 10.0, A_M2, R)
    worst = 0.0
    for p in run(pair, 1.0):
        s1, _ = surface_temperatures_finite_h_C(skin.b, 33.0, mat.b, 10.0, 1.0 / R, p.t_s)
        worst = max(worst, abs(p.T_surface_A_C - s1))
    assert worst <= 0.05, f"{force_N} N: {worst:.4f} °C"


def test_two_eight_and_twenty_newtons_differ():
    """The skin's surface 20 ms into a touch of aluminium differs between 2, 8 and 20 N by more than the
    closed form's tolerance, in the order of the force (more force: closer to eq. 1's contact temperature)."""
    skin, mat = materials()["skin"], materials()["aluminium"]
    s = [
        surface_temperatures_finite_h_C(skin.b, 33.0, mat.b, 10.0, 1.0 / contact_resistance_m2K_W(f), 0.002)[
            0
        ]
        for f in (2.0, 8.0, 20.0)
    ]
    Tc = contact_temperature_C(skin.b, 33.0, mat.b, 10.0)
    assert s[0] > s[1] + 0.05 and s[1] > s[2] + 0.05 and s[2] > Tc
