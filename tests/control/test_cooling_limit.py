"""The TEM's maximum-cooling current and the flux guard (issue 22: a lab's own module). The first is found
from the identified model and held by the envelope; it prevents a runaway into a surface trip on a
high-resistance module whose drive allows far more current than the module can use. The second keeps a big
module pressed on a cold or hot block below the flux plausibility trip."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import sim
from telethermo.control.cooling_limit import max_cooling_current_A
from telethermo.control.gain_rule import fitted_params
from telethermo.control.params import default_params
from telethermo.control.safety import EnvelopeState, limit_current
from telethermo.control.safety_limits import SafetyLimits
from telethermo.control.types import Role
from telethermo.ident.experiment import identify_rig
from telethermo.offline.envelope import Condition, base_condition, condition_scene, run_condition

# a module with 3.9x the resistance and 0.8x the Seebeck coefficient of the shipped one, behind a 5.9 A drive
# (envelope condition 12 of the matrix that found it): I* = alpha*T/R is about 0.8 A, the drive's limit 4.7 A
HIGH_R = dict(m_seebeck_x=0.8, m_R_x=3.87, m_I_max_A=5.91, m_K_x=1.0, m_sink_R_K_W=0.81)


@pytest.mark.parametrize("seebeck_x,R_x", [(0.8, 3.87), (0.6, 2.2), (1.0, 1.0), (2.0, 0.5)])
def test_the_identified_maximum_cooling_current_matches_the_physics(seebeck_x, R_x):
    """α·T/R of the simulated module (at the room temperature it was identified at) against the zero of the
    identified model's local input gain: within -35 %/+10 % (the sink's Joule heating lowers the real peak,
    so the estimate errs on the cold side), or no finding where the peak lies far beyond the drive."""
    sc, _ = condition_scene(base_condition())
    tem = dataclasses.replace(
        sc.rig_params.tem,
        alpha_V_K=sc.rig_params.tem.alpha_V_K * seebeck_x,
        R_ohm=sc.rig_params.tem.R_ohm * R_x,
    )
    rp = sc.rig_params.with_(tem=tem)
    rig = sim.free_pad_rig(period_s=sc.period_s, ambient_C=25.0, seed=3, params=rp)
    model, _ = identify_rig(rig, seed=3)
    est = max_cooling_current_A(model)
    phys = tem.peak_cooling_current_A(25.0)
    if phys > 8.0:  # far beyond any drive of the envelope (6 A): a finding is welcome, not required
        assert est > 3.0
    else:
        assert 0.65 * phys <= est <= 1.10 * phys, (est, phys)


def test_the_envelope_never_lets_more_cooling_through_than_the_module_can_use():
    lim = SafetyLimits(I_max_A=5.0, cooling_limit_A=0.7)
    st = EnvelopeState(setpoint_C=30.0)
    i, active = limit_current(lim, st, -3.0, 30.0, 30.0)
    assert i == pytest.approx(-0.7) and "current_limit" in active
    i, _ = limit_current(lim, st, 6.0, 30.0, 30.0)
    assert i == pytest.approx(4.0)  # heating keeps the whole 0.8·I_max: Peltier and Joule heat add
    assert SafetyLimits().I_cool_limit_A == SafetyLimits().I_limit_A  # unknown: no extra limit
    with pytest.raises(ValueError, match="cooling_limit_A"):
        SafetyLimits(cooling_limit_A=0.0)


@pytest.mark.slow
def test_a_high_resistance_module_saturates_at_its_cooling_peak_instead_of_running_away():
    """Before the limit this condition cut the session at 1.7 s (master surface_high: the controller asked
    for more cooling past I*, the Joule heat warmed the pad, it asked for more). With the limit identified
    from the module: no trip, no session-long cut, and the cooling current stays at the limit."""
    base = dataclasses.asdict(base_condition())
    base.update(HIGH_R, object_T_C=22.1, ambient_C=19.0, delay_ms=5.6, index=12)
    c = Condition(**base)
    r = run_condition(c, with_pads=False)
    cool = r["gain_fit"]["master"]["max_cooling_A"]
    sc, _ = condition_scene(c)
    assert cool is not None and cool < 0.6 * sc.rig_params.tem.I_max_A, cool
    assert r["trips"] == [] and not r["session_long_cut"], r["trips"]
    assert math.isfinite(r["headline_C"]) and np.isfinite(r["late_C"])


def test_the_node_holds_the_cooling_limit_of_its_model():
    """fitted_params: the identified model's cooling peak reaches the node's envelope (what nodes/parts.py
    and the envelope benchmark run)."""
    p = fitted_params(default_params(Role.MASTER, period_s=0.01), {"rho": 0.5, "max_cooling_A": 0.8})
    assert p.safety.cooling_limit_A == 0.8 and p.safety.I_cool_limit_A == 0.8
    q = fitted_params(default_params(Role.MASTER, period_s=0.01), {"rho": 0.5, "max_cooling_A": None})
    assert math.isinf(q.safety.cooling_limit_A)


def test_the_flux_guard_tapers_the_current_that_pushes_the_flux_towards_its_plausibility_limit():
    lim = SafetyLimits(I_max_A=5.0)  # Q_abs_max_W 30 W: the taper runs from 24 W to 28.5 W
    st = EnvelopeState(setpoint_C=30.0)
    assert limit_current(lim, st, 3.0, 30.0, 30.0, Q_W=20.0)[0] == pytest.approx(3.0)
    i, active = limit_current(lim, st, 3.0, 30.0, 30.0, Q_W=26.25)
    assert i == pytest.approx(2.0) and "guard" in active  # half way through the taper: half of 4 A
    assert limit_current(lim, st, 3.0, 30.0, 30.0, Q_W=29.0)[0] == 0.0
    assert limit_current(lim, st, -3.0, 30.0, 30.0, Q_W=29.0)[0] == pytest.approx(-3.0)  # pulling back passes
    assert limit_current(lim, st, -3.0, 30.0, 30.0, Q_W=-29.0)[0] == 0.0  # and the mirror case


@pytest.mark.slow
def test_a_big_probe_on_a_cold_metal_block_saturates_below_the_flux_trip():
    """Envelope condition 48 of the matrix: a 5.5 A probe module pressed at 14 N on a 5.9 °C block, asked to
    bring it to the finger's 26 °C, drew more than the 30 W flux plausibility limit and cut the session
    (slave sensor_range at 6.1 s). With the flux guard: no trip, no cut."""
    base = dataclasses.asdict(base_condition())
    base.update(
        index=48,
        materials=("copper", "brass", "oak"),
        object_T_C=5.9,
        ambient_C=16.2,
        delay_ms=31.0,
        probe_force_N=14.0,
        s_seebeck_x=2.2,
        s_R_x=1.0,
        s_I_max_A=5.5,
    )
    r = run_condition(Condition(**base), with_pads=False)
    assert r["trips"] == [] and not r["session_long_cut"], r["trips"]
    # the per-touch oscillation the session's flag and worst ratio are made of: the schedule's six touches
    touches = r["oscillation_touches"]
    assert len(touches) == 6 and {t["object"] for t in touches} == {"a", "b", "c"}, touches
    assert any(t["oscillating"] for t in touches) == r["oscillating"]
    assert max(t["ratio"] for t in touches) == r["oscillation_ratio"]
