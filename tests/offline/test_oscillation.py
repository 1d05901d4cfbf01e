"""The oscillation figure (issue 22): it tells a limit cycle from a settled touch, and sessions report it."""

from __future__ import annotations

import numpy as np

from telethermo.offline.oscillation import FLOOR_C, OSCILLATION_LIMIT, band_rms, oscillation_figures
from telethermo.offline.runner import run_offline_session


def _touch(t, amplitude_C, f_Hz=1.0):
    """A settled touch's skin: a slow exponential drift plus a sine of ``amplitude_C`` at f_Hz."""
    return 30.0 + 2.0 * np.exp(-t / 3.0) + amplitude_C * np.sin(2 * np.pi * f_Hz * t)


def test_a_limit_cycle_is_flagged_and_a_slow_drift_is_not():
    t = np.arange(0.0, 10.0, 0.01)
    contacts = [
        {"t_on_s": 1.0, "t_off_s": 4.5, "object": "a"},
        {"t_on_s": 6.0, "t_off_s": 9.5, "object": "b"},
    ]
    ref = _touch(t, 0.0)
    calm = oscillation_figures(t, ref + 0.3, ref, np.zeros_like(t), contacts)  # offset, no cycle
    assert not calm["oscillating"] and calm["worst_ratio"] <= OSCILLATION_LIMIT
    # the limit cycle: skin 3.4 °C peak to peak at about 1 Hz, current ±1.6 A
    cyc = oscillation_figures(t, _touch(t, 1.7), ref, 1.6 * np.sin(2 * np.pi * t), contacts)
    # (a 1.5 s window and its parabola keep at least 3/4 of a 1 Hz cycle's RMS)
    assert cyc["oscillating"] and cyc["worst_ratio"] > 15
    assert 0.75 * 1.7 / np.sqrt(2) < cyc["skin_band_rms_max_C"] <= 1.7 / np.sqrt(2) + 0.05
    assert 0.75 * 1.6 / np.sqrt(2) < cyc["current_band_rms_max_A"] <= 1.6 / np.sqrt(2) + 0.05
    # a fluctuation well below the floor is no oscillation, whatever the direct touch's own stillness
    tiny = oscillation_figures(t, _touch(t, 0.2 * FLOOR_C), ref, np.zeros_like(t), contacts)
    assert not tiny["oscillating"]
    # a skin that swings under a steady current is the pad settling, not the loop: reported, not flagged
    passive = oscillation_figures(t, _touch(t, 1.7), ref, np.full_like(t, -0.3), contacts)
    assert passive["worst_ratio"] > 15 and not passive["oscillating"]


def test_band_rms_ignores_what_lies_outside_the_band():
    t = np.arange(0.0, 3.0, 0.01)
    assert band_rms(0.1 * np.sin(2 * np.pi * 0.05 * t), 0.01) < 0.01  # slower than 0.3 Hz
    assert band_rms(0.5 * np.sin(2 * np.pi * 12.0 * t), 0.01) < 0.02  # faster than 5 Hz
    assert abs(band_rms(0.5 * np.sin(2 * np.pi * 2.0 * t), 0.01) - 0.5 / np.sqrt(2)) < 0.02


def test_the_base_scene_does_not_oscillate_and_the_summary_says_so():
    fig = run_offline_session("probe_touches_al_steel_wood", duration_s=15.0).figures  # touches 1-3
    osc = fig["oscillation"]
    assert len(osc["per_touch"]) == 3 and not osc["oscillating"]
    assert all(p["direct_band_rms_C"] < 0.05 for p in osc["per_touch"])
