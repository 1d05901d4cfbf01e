"""A sensor that has come off the pad (issue 24 item 4): telethermo.control.detach, its trip in the envelope.

Physics first: the holding current is the simulated TEM's own steady state, the shipped constants are the
simulator's module; then whole sessions (the offline runner: the controllers' step function on the simulated
rigs): a sensor head detached from either pad trips SENSOR_DETACHED (EMCY 0x5014) within a bounded time and
cuts the current, while the §5.3 scene and envelope corners (objects at 5 and 50 °C, rooms at 15 and 32 °C,
TEMs of half and 2.5 times the Seebeck coefficient, 100 ms delay) never do, with the leaky timer far below its
limit."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from telethermo import sim
from telethermo.control import safety as sf
from telethermo.control.core import init_state, step
from telethermo.control.detach import (
    SHIPPED_ALPHA_V_K,
    SHIPPED_K_W_K,
    SHIPPED_R_OHM,
    SHIPPED_TAU_V_K,
    detach_excess,
    detach_timer,
    hold_current_A,
    sensor_average,
    tem_limits,
)
from telethermo.control.params import default_params
from telethermo.control.types import Mode, Role
from telethermo.ident.plan import IdentifyPlan
from telethermo.iomodule.faults import FaultError, parse_faults
from telethermo.offline import run_offline_session
from telethermo.offline.envelope import base_condition, condition_scene, draw_conditions
from telethermo.sim.tem import load_rig_params

SCENE = "probe_touches_al_steel_wood"
DETACH_AT_S = 5.0
#: the bound on the time from detachment to the trip, s (measured 7.1 s on the slave, 8.2 s on the master)
BOUND_S = 10.0


def test_shipped_constants_are_the_simulated_module():
    tem = load_rig_params().tem
    assert (SHIPPED_ALPHA_V_K, SHIPPED_R_OHM, SHIPPED_K_W_K, SHIPPED_TAU_V_K) == pytest.approx(
        (tem.alpha_V_K, tem.R_ohm, tem.K_W_K, tem.tau_V_K), rel=1e-12
    )


@pytest.mark.parametrize("I_A", [-1.5, -0.4, 0.0, 0.3, 1.2, 2.0])
def test_hold_current_inverts_the_pad_plate_balance(I_A):
    """The pad plate's steady balance of sim.tem (Peltier, Joule, Thomson, conduction) at a current gives a
    load; the holding current of that load is the current again."""
    tem = load_rig_params().tem
    for T_p, T_s in ((33.0, 25.0), (15.0, 30.0), (45.0, 26.0)):
        _, u_p = tem.plate_heat_W(I_A, T_s, T_p)
        Q_load = u_p + tem.K_W_K * (T_s - T_p)
        got = hold_current_A(
            tem.alpha_V_K,
            tem.R_ohm,
            tem.K_W_K,
            tem.tau_V_K,
            T_pad_C=T_p,
            T_sink_C=T_s,
            Q_load_W=Q_load,
            I_limit_A=3.0,
        )
        assert got == pytest.approx(I_A, abs=1e-9)


def test_hold_current_limits_and_missing_inputs():
    a, R, K, tau = SHIPPED_ALPHA_V_K, SHIPPED_R_OHM, SHIPPED_K_W_K, SHIPPED_TAU_V_K
    assert hold_current_A(a, R, K, tau, T_pad_C=33, T_sink_C=25, Q_load_W=50.0, I_limit_A=2.4) == 2.4
    assert hold_current_A(a, R, K, tau, T_pad_C=33, T_sink_C=25, Q_load_W=-50.0, I_limit_A=2.4) == -2.4
    assert math.isnan(hold_current_A(a, R, K, tau, T_pad_C=33, T_sink_C=math.nan, Q_load_W=0, I_limit_A=2.4))


def test_the_check_needs_a_steady_sensor_and_a_real_excess():
    lim = sf.SafetyLimits(I_max_A=3.0)
    hold = hold_current_A(
        lim.tem_alpha_V_K,
        lim.tem_R_ohm,
        lim.tem_K_W_K,
        lim.tem_tau_V_K,
        T_pad_C=30.0,
        T_sink_C=25.0,
        Q_load_W=0.0,
        I_limit_A=lim.I_limit_A,
    )
    kw = dict(T_sink_C=25.0, Q_W=0.0)
    assert detach_excess(lim, T_sensor_C=30.0, T_avg_C=30.0, current_A=2.4, **kw)
    assert not detach_excess(lim, T_sensor_C=30.0, T_avg_C=30.0, current_A=hold + 0.5, **kw)  # within
    assert not detach_excess(lim, T_sensor_C=30.0, T_avg_C=29.0, current_A=2.4, **kw)  # moving 1 °C/s
    assert not detach_excess(lim, T_sensor_C=30.0, T_avg_C=math.nan, current_A=2.4, **kw)  # no average
    assert not detach_excess(
        dataclasses.replace(lim, tem_alpha_V_K=0.0), T_sensor_C=30.0, T_avg_C=30.0, current_A=2.4, **kw
    )  # off
    assert sensor_average(math.nan, 30.0, 0.01) == 30.0
    assert sensor_average(30.0, 31.0, 0.01) == pytest.approx(30.01)


def test_leaky_timer():
    lim = sf.SafetyLimits(I_max_A=3.0)
    t, tripped = 0.0, False
    for _ in range(150):  # 1.5 s in excess, 1.5 s not: back to 0
        t, tripped = detach_timer(lim, t, True, 0.01)
    for _ in range(150):
        t, _ = detach_timer(lim, t, False, 0.01)
    assert t == pytest.approx(0.0, abs=1e-9) and not tripped
    steps = 0
    while not tripped:
        t, tripped = detach_timer(lim, t, True, 0.01)
        steps += 1
    assert steps == round(lim.detach_time_s / 0.01)


def test_trip_code_bits_and_cut():
    trip = sf.Trip.SENSOR_DETACHED
    assert sf.EMCY_CODES[trip] == 0x5014 and len(set(sf.EMCY_CODES.values())) == len(sf.Trip)
    assert sf.trips_mask([trip]) == 0x800 and sf.trips_from_mask(0x800) == [trip]
    assert trip in sf.CUT_TRIPS and sf.error_register((trip,)) == 0x81


def _detached(role: str | None, duration_s: float):
    def path(rig, r):
        if r == role:
            rig.detach_sensor(DETACH_AT_S)
        return rig

    return run_offline_session(SCENE, duration_s=duration_s, rounding="real32", rig_path=path).recording


def _trip_times(rec, p: str, name: str) -> list[float]:
    t = rec.col("t_s")
    return [float(t[i]) for i, x in enumerate(rec.text(f"{p}_new_trips")) if name in x.split("|")]


@pytest.mark.slow  # two 14 s sessions of physics
@pytest.mark.parametrize("role", ["master", "slave"])
def test_a_detached_sensor_trips_with_its_own_code(role):
    rec = _detached(role, DETACH_AT_S + BOUND_S - 1.0)
    p, other = ("m", "s") if role == "master" else ("s", "m")
    times = _trip_times(rec, p, "sensor_detached")
    print(f"{role}: sensor_detached {times[0] - DETACH_AT_S:.2f} s after the detachment" if times else "none")
    assert times and DETACH_AT_S < times[0] <= DETACH_AT_S + BOUND_S
    # the first trip of that side, and the current cut from then on
    assert all(not x for x in rec.text(f"{p}_new_trips")[: int(round(times[0] / 0.01))])
    k = int(np.searchsorted(rec.col("t_s"), times[0]))
    assert np.all(rec.col(f"{p}_current_A")[k:] == 0.0)
    assert not _trip_times(rec, other, "sensor_detached")


def _max_timer(rec, p: str, lim: sf.SafetyLimits) -> float:
    """The leaky timer's largest value over a recording (the envelope's check replayed on its columns: the
    sample's current is the one commanded the step before)."""
    T, I = rec.col(f"{p}_T_sensor_C"), rec.col(f"{p}_current_A")
    sink, Q = rec.col(f"{p}_T_sink_C"), rec.col(f"{p}_Q_W")
    avg, timer, worst, prev = math.nan, 0.0, 0.0, 0.0
    for k in range(len(T)):
        ex = detach_excess(lim, T_sensor_C=T[k], T_avg_C=avg, current_A=prev, T_sink_C=sink[k], Q_W=Q[k])
        timer, _ = detach_timer(lim, timer, ex, 0.01)
        worst, avg, prev = max(worst, timer), sensor_average(avg, T[k], 0.01), I[k]
    return worst


# the §5.3 scene and envelope corners: cold (5 °C) and hot (50 °C) objects, rooms at 15 and 32 °C, TEMs with
# half and 2.5 times the Seebeck coefficient, a 100 ms delay (telethermo.offline.envelope)
CORNERS = {c.index: c for c in draw_conditions(0, 7, corners=True)}
CONDITIONS = [base_condition(), CORNERS[0], CORNERS[3], CORNERS[6], CORNERS[13]]


@pytest.mark.slow  # five 30 s sessions of physics
@pytest.mark.parametrize(
    "cond",
    CONDITIONS,
    ids=lambda c: f"obj{c.object_T_C:g}-room{c.ambient_C:g}-seebeck{c.m_seebeck_x:g}-delay{c.delay_ms:g}",
)
def test_contacts_hot_and_cold_objects_do_not_trip(cond):
    sc, rig_s = condition_scene(cond)
    rec = run_offline_session(
        sc,
        slave_rig_params=rig_s,
        seed=cond.seed % 100000,
        delay_cycles=int(round(cond.delay_ms * 1e-3 / sc.period_s)),
    ).recording
    assert rec.col("t_s")[-1] > 29.0 and len(sc.slave_contacts) == 6
    for p, params, role in (("m", sc.rig_params, Role.MASTER), ("s", rig_s, Role.SLAVE)):
        assert not _trip_times(rec, p, "sensor_detached")
        lim = default_params(role, period_s=sc.period_s, mode=Mode.TELEPRESENCE).safety
        lim = dataclasses.replace(lim, I_max_A=params.tem.I_max_A, **tem_limits(_Rig(params)))
        worst = _max_timer(rec, p, lim)
        print(f"{p}: leaky timer at most {worst:.2f} s of {lim.detach_time_s:g}")
        assert worst < 0.5 * lim.detach_time_s


class _Rig:
    """What tem_limits reads of a simulated rig: its parameters."""

    def __init__(self, params):
        self.params = params


def test_the_module_fault_text():
    """``telethermo-iomodule --fault detach:S`` (its session on the bus: tests/nodes/test_session_io.py)."""
    assert parse_faults(["detach:5"]).detach_at_s == 5.0 and parse_faults([]).detach_at_s is None
    for bad in ("detach:x", "detach:-1", "detach:inf", "detach"):
        with pytest.raises(FaultError, match="detach"):
            parse_faults([bad])


@pytest.mark.slow  # two identification experiments of 152 s of plant time
@pytest.mark.parametrize("role", [Role.MASTER, Role.SLAVE])
def test_the_identification_experiment_does_not_trip(role):
    """IDENTIFY drives PRBS currents up to 1 A into a pad in air, far from any holding current: the pad is not
    steady while a bit is held, and the bits above the margin are too rare for the leaky timer."""
    sc = sim.load_scene("pads_in_air")
    rig = sim.build_rig(sc, role.value, seed=1)
    plan = IdentifyPlan()
    p = default_params(role, period_s=sc.period_s, mode=Mode.IDENTIFY, identify=plan)
    p = dataclasses.replace(p, safety=dataclasses.replace(p.safety, I_max_A=rig.I_max_A, **tem_limits(rig)))
    state, worst, big = init_state(p, None, rig.read()), 0.0, 0
    for _ in range(plan.total):
        r = step(rig.read(), None, p, state)
        state = r.state
        assert not r.status.safety.new_trips
        worst, big = max(worst, state.env.detach_time_s), big + (abs(r.current_A) > p.safety.detach_excess_A)
        rig.apply_current(r.current_A)
        rig.advance(sc.period_s)
    print(f"{role.value}: leaky timer at most {worst:.2f} s; {big} of {plan.total} samples above the margin")
    assert big > 1000 and worst < 0.5 * p.safety.detach_time_s
