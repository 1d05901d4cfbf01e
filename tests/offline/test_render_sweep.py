"""Render mode across the envelope's object temperatures (issue 22 item 5): what limits the worst touch inside
the clamp band. Aluminium at 15 °C: eq. 1 gives a 15.7 °C contact, inside [15.5, 42.5] °C, but eq. 7 asks the
pad to wait at ≈ 7.6 °C so that the finger lands on 15.7 °C; the skin clamp holds the pre-set at 15 °C."""

from __future__ import annotations

import pytest

from telethermo.offline.render_sweep import BAND_MARGIN_C, render_touch, summarise

pytestmark = pytest.mark.slow  # two offline render sessions, a few seconds


def test_the_pre_set_clamp_is_what_limits_a_cold_metal_inside_the_band():
    r = render_touch("aluminium", 15.0)
    assert r["inside_band"] and 15.0 + BAND_MARGIN_C <= r["T_contact_eq1_C"] <= 16.5
    assert r["preset_asked_C"] == pytest.approx(15.0, abs=1e-6) and "preset_clamp" in r["limited_by"]
    # held at the clamp the pad meets the finger far too warm: the early skin error is several °C ...
    assert r["early_rms_C"] > 2.5
    # ... with the clamps widened (research envelope) eq. 7 pre-sets below 10 °C and the early error is a
    # fraction of a degree: the clamp, not the controller, is what the figure measures
    assert r["preset_unclamped_C"] < 10.0 and r["early_rms_unclamped_C"] < 1.0
    # and the skin itself then goes below the skin clamp: the limit would have to act on the skin
    assert r["skin_extreme_unclamped_C"] < 15.0
    s = summarise([r, render_touch("oak", 25.0)])
    assert s["render_inside_band_preset_clamped"] == 1
    assert s["render_early_rms_worst_not_clamped_C"] < 0.5 < s["render_early_rms_worst_C"]
