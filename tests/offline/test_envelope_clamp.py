"""Issue 22, item 4: how near the operator's skin comes to a clamp the direct touch passes, and its baseline,
a pad held at that clamp by the node's own envelope (telethermo.offline.envelope.clamp_figures). Two things
keep that pad's skin off the clamp, and the baseline shows both: the envelope's guard (no current towards a
clamp within 0.5 °C of it) and taper (from 2.5 °C) act on the pad's estimate, whatever the finger; and the
finger's contact resistance, which falls with its force (sim/contact.py), keeps a light finger's skin
degrees off the pad."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from telethermo.offline.envelope import (
    SKIN_CLAMP_C,
    base_condition,
    clamp_figures,
    condition_scene,
    hold_skin,
)

LOW = SKIN_CLAMP_C[0]


def _cold(finger_force_N: float):
    c = dataclasses.replace(
        base_condition(), object_T_C=5.0, ambient_C=20.0, finger_force_N=finger_force_N, index=0
    )
    return condition_scene(c)[0]


def test_a_pad_held_at_the_low_clamp_stops_short_by_the_guard_and_a_light_finger_further():
    firm, light = (float(np.min(hold_skin(_cold(F), LOW))) for F in (8.0, 0.5))
    # 8 N: the contact conducts (R'' 8e-6 m²·K/W), the skin sits on the pad, and the pad stops where the
    # taper's cooling current meets the finger's heat, past the guard's 0.5 °C (measured 15.93 °C)
    assert LOW + 0.5 <= firm < LOW + 1.2, firm
    # 0.5 N: R'' 2e-3 m²·K/W, the perfused finger's heat drops degrees across the contact (measured 19.8 °C)
    assert light > firm + 2.5, (firm, light)


def test_the_baseline_is_computed_only_where_the_direct_touch_passes_a_clamp():
    sc = _cold(8.0)
    n = int(round(sc.duration_s / sc.period_s))
    inside = clamp_figures(sc, np.full(n, 25.0), np.full(n, 20.0))
    assert inside == {"clamp_short_C": None, "clamp_short_pad_C": None}
    direct = np.concatenate([np.full(n // 2, 33.0), np.full(n - n // 2, 10.0)])
    f = clamp_figures(sc, np.full(n, 18.0), direct)
    assert f["clamp_short_C"] == pytest.approx(3.0)
    assert 0.5 <= f["clamp_short_pad_C"] < 1.2  # the firm finger on the pad held at 15 °C: the guard's margin
