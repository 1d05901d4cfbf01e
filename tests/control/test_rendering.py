"""Yamamoto's rendering formulas (eq. 1, 5, 7), β from profiles, finger calibration, render table."""

import math

import numpy as np
import pytest
from scipy.special import erfcx

from telethermo.control.rendering import (
    calibrate_finger,
    contact_temperature,
    load_render_table,
    pad_preset_temperature,
    pad_preset_temperature_abs,
    relative_effusivity_from_contact,
    relative_effusivity_from_profiles,
)

TABLE = load_render_table()


def test_table_is_yamamoto_table1():
    """The first five entries are yamamoto's Table 1 (their positions are the OD's material codes 1..5);
    the simulator's materials follow (issue 15)."""
    assert dict(list(TABLE.items())[:5]) == {
        "contact_pad": 2.23,
        "eps": 0.043,
        "wood": 0.74,
        "ceramic": 2.23,
        "brass": 5.60,
    }
    assert list(TABLE)[5:] == ["pvc", "glass", "stainless_steel", "carbon_steel", "aluminium", "copper"]


@pytest.mark.parametrize("material", ["eps", "wood", "ceramic", "brass"])
def test_preset_makes_pad_contact_equal_object_contact(material):
    """Eq. 4: touching the pad pre-set by eq. 7 gives the contact temperature of the object (eq. 1)."""
    Tf, To, bp = 33.0, 25.8, TABLE["contact_pad"]
    bo = TABLE[material]
    Tp0 = pad_preset_temperature(Tf, To, bo, bp)
    assert math.isclose(
        contact_temperature(Tf, 1.0, Tp0, bp), contact_temperature(Tf, 1.0, To, bo), abs_tol=1e-12
    )


def test_preset_values_for_table1():
    # hand-computed from eq. 7 with T_f0 = 33 °C, T_obj0 = 26 °C (yamamoto's room 25.8-26.3 °C)
    Tf, To = 33.0, 26.0
    got = {m: pad_preset_temperature(Tf, To, TABLE[m], 2.23) for m in ("eps", "wood", "ceramic", "brass")}
    assert got["ceramic"] == pytest.approx(26.0, abs=1e-12)  # pad = ceramic: pre-set = object temperature
    Tc_wood = (33 + 0.74 * 26) / 1.74
    assert got["wood"] == pytest.approx(Tc_wood * 3.23 / 2.23 - 33 / 2.23, abs=1e-12)
    # the order: higher effusivity object -> colder pre-set
    assert got["eps"] > got["wood"] > got["ceramic"] > got["brass"]


def test_eq5_equals_eq7_with_relative_effusivities():
    bf = 1100.0
    for bo, bp in ((47.0, 2450.0), (814.0, 2453.0), (6160.0, 2453.0)):
        a = pad_preset_temperature_abs(33.0, bf, 25.0, bo, bp)
        b = pad_preset_temperature(33.0, 25.0, bo / bf, bp / bf)
        assert a == pytest.approx(b, abs=1e-10)


def _semi_infinite_pair(t, Tf0, To0, bf, bo, h):
    """Surface temperatures of two semi-infinite bodies with a contact conductance h (Carslaw & Jaeger):
    both surfaces see the same flux q(t); dT_f = -q*t-kernel/bf, dT_o = +kernel/bo."""
    # with contact resistance: T_o,s - T_o0 = (Tf0-To0)*bf/(bf+bo)*(1 - exp(x^2) erfc(x)), x = h
    # sqrt(t)(1/bf+1/bo)
    x = h * np.sqrt(t) * (1 / bf + 1 / bo)
    g = 1 - erfcx(x)
    dT = Tf0 - To0
    To = To0 + dT * bf / (bf + bo) * g
    Tf = Tf0 - dT * bo / (bf + bo) * g
    return Tf, To


@pytest.mark.parametrize("beta,h", [(0.043, 5e4), (0.74, 2e3), (2.23, 1e5), (5.6, 800.0)])
def test_beta_from_profiles_recovers_ratio_whatever_the_contact_resistance(beta, h):
    bf = 1100.0
    t = np.arange(-0.5, 2.0, 0.01)
    tc = np.clip(t, 0, None)
    Tf, To = _semi_infinite_pair(tc, 33.5, 24.0, bf, beta * bf, h)
    rng = np.random.default_rng(1)
    Tf = Tf + rng.normal(0, 0.002, t.size)
    To = To + rng.normal(0, 0.002, t.size)
    got = relative_effusivity_from_profiles(t, Tf, To, 0.0)
    assert got == pytest.approx(beta, rel=0.03)


def test_beta_from_contact_and_errors():
    assert relative_effusivity_from_contact(
        33.0, 25.0, contact_temperature(33.0, 1.0, 25.0, 0.74)
    ) == pytest.approx(0.74)
    with pytest.raises(ValueError, match="strictly between"):
        relative_effusivity_from_contact(33.0, 25.0, 20.0)


def test_calibrate_finger_recovers_beta_pad_and_finger_temperature():
    beta_pad, Tf0 = 1.9, 33.4
    pre = np.array([24.0, 28.0, 38.0])
    Tc = np.array([contact_temperature(Tf0, 1.0, p, beta_pad) for p in pre])
    Tc = Tc + np.array([0.01, -0.02, 0.01])
    cal = calibrate_finger(pre, Tc)
    assert cal.beta_pad == pytest.approx(beta_pad, rel=0.03)
    assert cal.T_finger0_C == pytest.approx(Tf0, abs=0.15)
    one = calibrate_finger([24.0], [contact_temperature(Tf0, 1.0, 24.0, beta_pad)], T_finger0_C=Tf0)
    assert one.beta_pad == pytest.approx(beta_pad, rel=1e-9)


def test_calibrate_finger_refuses_uninformative_touches():
    with pytest.raises(ValueError, match=">= 2 touches"):
        calibrate_finger([25.0], [28.0])
    with pytest.raises(ValueError, match="slope"):
        calibrate_finger([25.0, 30.0], [35.0, 20.0])


def test_render_table_errors_name_file_and_field(tmp_path):
    p = tmp_path / "t.toml"
    p.write_text("[wood]\nbeta = -1\n")
    with pytest.raises(ValueError, match=r"t\.toml: \[wood\] beta: expected a number > 0, got -1$"):
        load_render_table(p)
    p.write_text("[wood\n")
    with pytest.raises(ValueError, match=r"t\.toml: line 1: not valid TOML"):
        load_render_table(p)
