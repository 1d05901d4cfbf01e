"""TEM: datasheet derivation, steady state against guiatni eq. 5/6, sign conventions."""

from __future__ import annotations

import numpy as np
import pytest

from telethermo import sim
from telethermo.sim.compile import build_rig
from telethermo.sim.tem import KELVIN, TEMParams, load_rig_params
from tests.sim.conftest import make_scene


def eq5_eq6(p: TEMParams, I: float, T_hot_C: float, T_cold_C: float) -> tuple[float, float]:
    """guiatni eq. 6 (P_h) and eq. 5 (P_c), written out here independently of sim.tem."""
    i, dT = abs(I), T_hot_C - T_cold_C
    thomson = (1 if I > 0 else -1) * p.tau_V_K * i * dT / 2
    Pc = p.alpha_V_K * (T_cold_C + KELVIN) * i + thomson - p.R_ohm * i * i / 2 - p.K_W_K * dT
    Ph = p.alpha_V_K * (T_hot_C + KELVIN) * i + thomson + p.R_ohm * i * i / 2 - p.K_W_K * dT
    return Ph, Pc


def steady(rig, I, dt=20.0, steps=400):
    rig.apply_current(I)
    prev = None
    for _ in range(steps):
        rig.advance(dt)
        cur = rig.x.copy()
        if prev is not None and np.max(np.abs(cur[:-1] - prev[:-1])) < 1e-10:
            break
        prev = cur
    return rig


@pytest.mark.parametrize("I", [-1.5, -1.0, -0.5, -0.1, 0.1, 0.5, 1.0, 1.5])
def test_steady_state_matches_guiatni_eq5_eq6(I):
    scene = make_scene(master=[(0.0, 1e5, "finger", 8.0)], duration=1e5)
    rig = steady(build_rig(scene, "master", noise=False), I)
    sysm = rig.cfg.system
    x = rig.x[: sysm.n]
    f0, c0 = sysm.link_flux_functional(0)  # sink -> sink plate
    f2, c2 = sysm.link_flux_functional(2)  # pad plate -> sensor
    q_sink_to_plate = float(f0 @ x + c0)
    q_plate_to_sensor = float(f2 @ x + c2)
    Ts, Tp = x[1], x[2]
    p = rig.params.tem
    if I > 0:  # pad is the hot side
        Ph, Pc = eq5_eq6(p, I, Tp, Ts)
        sim_Ph, sim_Pc = q_plate_to_sensor, q_sink_to_plate
    else:  # sink plate is the hot side
        Ph, Pc = eq5_eq6(p, I, Ts, Tp)
        sim_Ph, sim_Pc = -q_sink_to_plate, -q_plate_to_sensor
    assert sim_Ph == pytest.approx(Ph, rel=0.01, abs=1e-4)
    assert sim_Pc == pytest.approx(Pc, rel=0.01, abs=1e-4)
    # and the balance of the module: P_h − P_c = electrical power α·I·ΔT + R·I²
    assert sim_Ph - sim_Pc == pytest.approx(p.alpha_V_K * abs(I) * abs(Tp - Ts) + p.R_ohm * I * I, rel=1e-6)


def test_datasheet_derivation_reproduces_dTmax_and_Qmax():
    """With the hot side held at Th (ideal sink) and no load, I = Imax gives ΔTmax (the derivation's premise),
    and the implied Qmax is within 15 % of the datasheet's (reported in docs/sim.md)."""
    base = load_rig_params()
    tem = TEMParams.from_datasheet(3.0, 3.75, 67.0, 27.0, tau_V_K=0.0, plate_C_J_K=0.62)
    params = base.with_(tem=tem, sink_R_K_W=1e-5, G_sink_plate_W_K=1e6, h_air_W_m2K=1e-9)
    rig = sim.free_pad_rig(ambient_C=27.0, noise=False, params=params)
    steady(rig, -tem.I_max_A)  # cool the pad: the pad is the cold side
    x = rig.x
    assert x[1] - x[2] == pytest.approx(67.0, rel=0.01)
    assert tem.Qmax_W(27.0) == pytest.approx(6.2, rel=0.15)


def test_sign_conventions_positive_current_heats_the_pad():
    rig = sim.free_pad_rig(noise=False)
    rig.apply_current(1.0)
    for _ in range(200):
        rig.advance(0.01)
    t = rig.truth()
    assert t.T_pad_C > 25.5 and t.T_sensor_true_C > 25.3
    assert t.Q_true_W > 0  # heat flows out of the pad into the air
    assert t.T_sink_C < 25.0  # the sink side is pumped
    rig = sim.free_pad_rig(noise=False)
    rig.apply_current(-1.0)
    for _ in range(200):
        rig.advance(0.01)
    assert rig.truth().T_pad_C < 24.5


def test_current_is_clipped_to_the_drive_limit():
    rig = sim.free_pad_rig(noise=False)
    rig.apply_current(10.0)
    rig.advance(0.01)
    assert rig.read().current_A == rig.I_max_A == 3.0
    rig.apply_current(float("nan"))
    rig.advance(0.01)
    assert rig.read().current_A == 0.0
