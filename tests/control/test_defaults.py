"""One defaults object: every default number of CoreParams comes from telethermo.control.defaults."""

import dataclasses

import pytest

from telethermo.control import defaults
from telethermo.control.core import CoreParams, RenderSettings
from telethermo.control.pi import FluxPIGains, PIGains
from telethermo.control.params import default_params
from telethermo.control.types import Mode, Role


@pytest.mark.parametrize("role", [Role.MASTER, Role.SLAVE])
def test_core_params_field_defaults_are_the_defaults_object(role):
    p = CoreParams(role=role)
    numeric = {f.name for f in dataclasses.fields(CoreParams) if f.init and isinstance(f.default, float)}
    assert numeric == set(defaults.CORE)  # no number of CoreParams is written anywhere else
    for name, value in defaults.CORE.items():
        assert getattr(p, name) == value, name


@pytest.mark.parametrize("role", [Role.MASTER, Role.SLAVE])
def test_default_params_lay_the_role_gains_over_the_field_defaults(role):
    p = default_params(role)
    for name, value in defaults.GAINS[role].items():
        assert getattr(p, name) == value, name
    assert p.gains == PIGains(defaults.GAINS[role]["kp_A_per_C"], defaults.GAINS[role]["ki_A_per_C_s"])
    assert p.flux_gains == FluxPIGains(
        defaults.GAINS[role]["kpQ_A_per_W"], defaults.GAINS[role]["kiQ_A_per_W_s"]
    )


def test_render_mode_takes_the_render_gains():
    p = default_params(Role.MASTER, mode=Mode.RENDER, render=RenderSettings(0.74, 25.0))
    assert (p.kp_A_per_C, p.ki_A_per_C_s) == (
        defaults.RENDER_GAINS["kp_A_per_C"],
        defaults.RENDER_GAINS["ki_A_per_C_s"],
    )
    assert p.kpQ_A_per_W == defaults.CORE["kpQ_A_per_W"] and p.flux_gains is None
