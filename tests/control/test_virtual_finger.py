"""The probe's virtual finger (telethermo.control.virtual_finger; an experiment, off by default): a
semi-infinite skin driven by the probe's measured flux, checked against the closed form, and how the core
uses it on the slave in contact."""

from __future__ import annotations

import math

import pytest

from telethermo.control.core import CoreParams, init_state, step
from telethermo.control.types import PeerValues, Role
from telethermo.control.virtual_finger import VF_AREA_M2, vf_model, vf_start, vf_step, vf_step_held
from telethermo.rig import RigSample


def _constant_flux_drop(b: float, Q_W: float, t_s: float, dt_s: float = 0.01) -> float:
    m = vf_model(b, VF_AREA_M2, dt_s)
    x = vf_start(m, 34.0)
    T = 34.0
    for _ in range(int(round(t_s / dt_s))):
        x, T = vf_step(m, x, Q_W)
    return 34.0 - T


@pytest.mark.parametrize("b", [600.0, 1100.0, 2000.0])
@pytest.mark.parametrize("t_s", [0.5, 3.0])
def test_a_constant_flux_cools_the_skin_as_a_semi_infinite_body(b, t_s):
    Q = 0.5  # W leaving the skin over the probe's 15 x 15 mm
    exact = 2.0 * (Q / VF_AREA_M2) * math.sqrt(t_s) / (b * math.sqrt(math.pi))  # Carslaw & Jaeger 2.9
    assert _constant_flux_drop(b, Q, t_s) == pytest.approx(exact, rel=0.03)


@pytest.mark.parametrize("b", [600.0, 1100.0, 2000.0])
@pytest.mark.parametrize("t_s", [0.1, 0.5, 3.0])
def test_a_surface_held_at_a_step_draws_the_semi_infinite_bodys_heat(b, t_s):
    # the admittance form: the surface held 10 °C above the skin's start draws q = b·A·ΔT/√(π·t) (Carslaw &
    # Jaeger 2.5), the heat over each period evaluated at its middle
    m = vf_model(b, VF_AREA_M2, 0.01)
    x = vf_start(m, 33.0)
    n = int(round(t_s / 0.01))
    for _ in range(n):
        x, q = vf_step_held(m, x, 43.0)
    exact = b * VF_AREA_M2 * 10.0 / math.sqrt(math.pi * (n - 0.5) * 0.01)
    assert q == pytest.approx(exact, rel=0.04)
    assert vf_step_held(m, vf_start(m, 33.0), 33.0)[1] == pytest.approx(0.0, abs=1e-12)  # no step, no heat
    assert vf_step_held(m, x, math.nan)[1] == 0.0  # a bad reading counts as no heat


def test_no_flux_no_change_and_a_bad_flux_counts_as_none():
    m = vf_model(1100.0, VF_AREA_M2, 0.01)
    x = vf_start(m, 33.2)
    for q in (0.0, math.nan, math.inf):
        x, T = vf_step(m, x, q)
        assert T == pytest.approx(33.2, abs=1e-12)
    with pytest.raises(ValueError, match="vf_model: b must be a finite number > 0"):
        vf_model(0.0, VF_AREA_M2, 0.01)


def S(t=0.0, T=30.0, Q=0.0, contact=False):
    return RigSample(t, T, Q, 0.0, contact, 26.0)


def test_in_contact_the_slave_follows_its_virtual_finger_not_the_peer():
    peer = PeerValues(33.0, -0.4)  # the master's finger estimate and flux
    on = CoreParams(role=Role.SLAVE, virtual_finger_b=1100.0)
    off = CoreParams(role=Role.SLAVE)
    assert off.virtual_finger is None and on.virtual_finger is not None
    assert CoreParams(role=Role.MASTER, virtual_finger_b=1100.0).virtual_finger is None  # the probe's only
    vf = on.virtual_finger
    x = vf_start(vf, 33.0)
    st_on, st_off = init_state(on, None, S()), init_state(off, None, S())
    for k in range(1, 40):
        s = S(t=0.01 * k, Q=0.8, contact=True)  # the probe gives the object 0.8 W
        r_on, r_off = step(s, peer, on, st_on), step(s, peer, off, st_off)
        st_on, st_off = r_on.state, r_off.state
        x, T_vf = vf_step(vf, x, 0.8)
        assert r_on.status.requested_setpoint_C == pytest.approx(T_vf, abs=1e-9)
        assert r_off.status.requested_setpoint_C == 33.0
        assert r_on.status.pi.ff_A == 0.0  # no flux feed-forward from the peer
    assert T_vf < 33.0 - 0.5  # the virtual skin has cooled, the peer's estimate has not moved
    # the touch ends (once the contact detector opens): the peer's estimate again
    for k in range(40, 400):
        r = step(S(t=0.01 * k, Q=0.0, contact=False), peer, on, st_on)
        st_on = r.state
        if not r.status.contact:
            break
    assert not r.status.contact and r.status.requested_setpoint_C == 33.0
