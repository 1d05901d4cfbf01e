"""The identification plan: one definition of the experiment, offline and inside a node's control core."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from telethermo import sim
from telethermo.control.core import init_state, step
from telethermo.control.params import default_params
from telethermo.control.types import Mode, Role
from telethermo.ident.experiment import ExperimentSettings, identify_rig, run_excitation
from telethermo.ident.plan import IdentifyPlan, guarded_current
from telethermo.ident.prbs import prbs


def test_plan_is_rest_then_training_then_heldout_prbs():
    plan = IdentifyPlan(
        seed=9,
        rest_samples=50,
        train_samples=400,
        validation_samples=300,
        amplitude_A=(0.2, 0.7),
        hold_samples=7,
    )
    u = plan.currents()
    assert len(u) == plan.total == 750 and not u.flags.writeable
    assert np.all(u[:50] == 0.0)
    np.testing.assert_array_equal(u[50:450], prbs(400, amplitude_A=(0.2, 0.7), hold_samples=7, seed=9))
    np.testing.assert_array_equal(u[450:], prbs(300, amplitude_A=(0.2, 0.7), hold_samples=7, seed=10))
    assert 0.2 - 1e-12 <= np.abs(u[50:]).min() and np.abs(u[50:]).max() <= 0.7 + 1e-12
    assert [plan.phase(j) for j in (0, 49, 50, 449, 450, 749, 750)] == [
        "rest",
        "rest",
        "train",
        "train",
        "validation",
        "validation",
        "done",
    ]
    assert plan.current_at(750) == 0.0 and plan.current_at(-1) == 0.0


@pytest.mark.parametrize(
    "kw, field",
    [
        ({"seed": -1}, "seed"),
        ({"seed": 70000}, "seed"),
        ({"train_samples": 0}, "train_samples"),
        ({"hold_samples": 0}, "hold_samples"),
        ({"amplitude_A": (0.5, 0.2)}, "amplitude_A"),
        ({"amplitude_A": (0.1, float("inf"))}, "amplitude_A"),
        ({"rest_samples": True}, "rest_samples"),
        ({"margin_C": -1.0}, "margin_C"),
    ],
)
def test_bad_plans_name_the_field(kw, field):
    with pytest.raises(ValueError, match=f"IdentifyPlan.{field}"):
        IdentifyPlan(**kw)


def test_guard():
    kw = dict(I_limit_A=2.4, T_min_C=15.0, T_max_C=43.0, margin_C=1.0)
    assert guarded_current(5.0, 30.0, **kw) == (2.4, False)  # clipped, not guarded
    assert guarded_current(0.8, 42.2, **kw) == (-0.8, True)  # heating near the top: cooling
    assert guarded_current(-0.8, 42.2, **kw) == (-0.8, False)  # cooling near the top passes
    assert guarded_current(-0.8, 15.5, **kw) == (0.8, True)
    assert guarded_current(0.8, float("nan"), **kw) == (0.0, True)


def test_the_core_runs_the_same_experiment_as_the_offline_one():
    """IDENTIFY in the control core (what a node runs) commands, sample for sample, the currents that
    run_excitation commands on an identical simulated rig: a live identification is the offline one."""
    settings = ExperimentSettings()
    plan = settings.plan(seed=5, train_samples=2000, validation_samples=600)
    rig_off, rig_core = sim.free_pad_rig(seed=7), sim.free_pad_rig(seed=7)
    rec = run_excitation(rig_off, plan.currents(), settings=settings)
    p = default_params(Role.MASTER, period_s=rig_core.period_s, mode=Mode.IDENTIFY, identify=plan)
    p = dataclasses.replace(p, safety=dataclasses.replace(p.safety, I_max_A=rig_core.I_max_A))
    state, I, T = None, [], []
    for k in range(plan.total):
        if k:
            rig_core.advance(rig_core.period_s)
        smp = rig_core.read()
        state = init_state(p, None, smp) if state is None else state
        res = step(smp, None, p, state)
        state = res.state
        rig_core.apply_current(res.current_A)
        I.append(res.current_A)
        T.append(smp.T_sensor_C)
    np.testing.assert_array_equal(np.array(I), rec.current_A)
    np.testing.assert_array_equal(np.array(T), rec.T_C)
    assert state.ident_k == plan.total and state.ident_guard == rec.guard_interventions
    assert np.abs(rec.current_A).max() > 0.9  # the experiment did drive the pad


def test_identify_rig_report_names_its_plan():
    tem, rep = identify_rig(
        sim.free_pad_rig(seed=1),
        n_samples=1500,
        n_validation=500,
        seed=2,
        orders=__import__("telethermo.ident", fromlist=["NarmaOrders"]).NarmaOrders(2, 2, 1, 1),
        method="ls",
    )
    assert rep["plan"]["train_samples"] == 1500 and rep["plan"]["seed"] == 2
    assert rep["heldout_free_run_max_C"] < 1.0 and rep["experiment_wall_s"] > 0
