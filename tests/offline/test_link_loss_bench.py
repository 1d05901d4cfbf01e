"""The link-loss figures (quick: carbon steel and oak, 20 mm blocks): while the slave is lost during a touch,
the
master's fallback keeps the operator's skin closer to the direct touch than the ramp to neutral does, and it
really renders (the master's setpoint is the identified material's, not neutral)."""

from __future__ import annotations

import json

import numpy as np

from telethermo.offline.link_loss import LOSS_S, RENDER_S, link_loss_figures, run_object


def test_fallback_beats_the_neutral_ramp():
    figs = link_loss_figures(quick=True)
    json.dumps(figs)
    assert figs["link_loss_fallback_error_C"] < figs["link_loss_neutral_ramp_error_C"] / 2
    for row in figs["link_loss"]:
        assert row["fallback_C"] < row["neutral_ramp_C"], row


def test_fallback_skin_follows_the_direct_touch_of_steel():
    r = run_object("carbon_steel")
    tr = r["traces"]
    m = (tr["t"] >= LOSS_S + 1.0) & (tr["t"] < LOSS_S + RENDER_S)  # after the ramp from telepresence
    fb = np.abs(tr["fallback"][m] - tr["direct"][m])
    ramp = np.abs(tr["neutral_ramp"][m] - tr["direct"][m])
    assert np.median(fb) < 1.0 and np.median(ramp) > 4.0
