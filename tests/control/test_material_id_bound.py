"""The oracle ceiling of material identification (telethermo/offline/material_oracle.py): physics of its two
limits."""

from __future__ import annotations

import numpy as np

from telethermo.offline.material_touches import AMBIENT_C, PERIOD_S, SIM_TO_TABLE, finger_natural_C
from telethermo.offline.material_oracle import noise_scale, oracle_answers, oracle_correct, touch_candidates
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


def _oracle_window(mat: str, window_s: float) -> float:
    """The unknown-nuisance oracle's accuracy on a 0.5 mm slab of ``mat`` 3 K below the probe at 1 N, seeing
    ``window_s`` of contact."""
    T_probe = finger_natural_C(PARAMS)
    touch = {"class": SIMS.index(mat), "force_N": 1.0, "T_object_C": T_probe - 3.0, "thickness_m": 0.5e-3}
    touch["t_on_s"] = 0.205
    sigma = noise_scale(NoiseParams(), int(round(window_s / PERIOD_S)))
    z, G = touch_candidates(PARAMS, SIMS, touch, T_probe, PERIOD_S, AMBIENT_C, sigma, window_s)
    _, named = oracle_answers(z, G, touch["class"], np.random.default_rng(0), draws=300)
    return float(np.mean(named == touch["class"]))


def test_a_thin_slab_needs_the_refined_window():
    """A 0.5 mm aluminium sheet at 1 N: its heat capacity (ρ·c·d ≈ 1.2 kJ/(m²·K)) drains through the contact
    resistance (R'' = 5e-4 m²·K/W) with a time constant of about 0.6 s, so 0.3 s of contact shows only the
    start and leaves it among the metals; 1.2 s names it in (almost) every draw. PVC's thin sheet likewise
    separates from oak. The refined answer's oracle must be computed over the refined answer's window."""
    for mat in ("aluminium", "pvc"):
        short, long = _oracle_window(mat, 0.3), _oracle_window(mat, 1.2)
        assert short < 0.7 and long > 0.95, (mat, short, long)
