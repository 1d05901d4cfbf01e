"""The oracle ceiling of material identification (telethermo/offline/material_oracle.py): physics of its two
limits."""

from __future__ import annotations

import numpy as np

from telethermo.offline.material_touches import AMBIENT_C, PERIOD_S, SIM_TO_TABLE, finger_natural_C
from telethermo.offline.material_oracle import oracle_correct, touch_candidates, noise_scale
from telethermo.sim.measurement import NoiseParams
from telethermo.sim.tem import load_rig_params

PARAMS = load_rig_params()
SIMS = list(SIM_TO_TABLE)


def _oracle(mat: str, dT_C: float, force_N: float = 8.0, thickness_m: float = 0.02) -> tuple[float, float]:
    T_probe = finger_natural_C(PARAMS)
    touch = {
        "class": SIMS.index(mat),
        "force_N": force_N,
        "T_object_C": T_probe + dT_C,
        "thickness_m": thickness_m,
        "t_on_s": 0.205,
    }
    sigma = noise_scale(NoiseParams(), int(round(0.3 / PERIOD_S)))
    z, G = touch_candidates(PARAMS, SIMS, touch, T_probe, PERIOD_S, AMBIENT_C, sigma)
    return oracle_correct(z, G, touch["class"], np.random.default_rng(0), draws=300)


def test_information_grows_with_the_temperature_difference():
    """Copper at the probe's temperature: hardly any heat flows (only the probe's own small loss to the
    air before the touch), the oracle that must also find the contact resistance, the object's temperature
    and its thickness names it in fewer than half of the noise draws; 1 K colder, in (almost) all."""
    _, at_probe = _oracle("copper", 0.0)
    _, one_kelvin = _oracle("copper", -1.0)
    assert at_probe < 0.5 < 0.9 < one_kelvin


def test_a_large_temperature_difference_identifies_glass():
    """Glass at 13 °C below the probe: the oracle names it in (almost) every noise draw."""
    known, unknown = _oracle("glass", -13.0)
    assert known > 0.98 and unknown > 0.9
