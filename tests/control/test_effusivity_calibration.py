"""Relative effusivity from a simulated contact profile, and the per-user finger calibration session."""

import numpy as np
import pytest

from telethermo.control.rendering import relative_effusivity_from_profiles

sim = pytest.importorskip("sim")
from telethermo.sim.bodies import FingerParams, finger_segment, slab  # noqa: E402
from telethermo.sim.materials import material  # noqa: E402
from telethermo.sim.pair import ContactPair  # noqa: E402


@pytest.mark.parametrize("mat", ["eps", "oak", "ceramic", "brass", "aluminium"])
def test_beta_from_simulated_finger_object_profiles(mat):
    """Yamamoto §III-B on the simulator's layered, perfused finger: drop/rise = b_object/b_skin."""
    A = 2.25e-4
    pair = ContactPair(
        finger_segment(FingerParams(), A, 0.01),
        33.0,
        slab("obj", material(mat), 0.02, A, 0.01, 1.3, 4.0),
        25.0,
        A,
    )
    t, Tf, To = list(np.arange(-0.3, 0.0, 0.01)), [33.0] * 30, [25.0] * 30
    for _ in range(150):
        pair.advance(0.01)
        t.append(pair.t_s)
        Tf.append(pair.T_surface_A_C)
        To.append(pair.T_surface_B_C)
    beta = relative_effusivity_from_profiles(t, Tf, To, 0.0)
    assert beta == pytest.approx(material(mat).b / material("skin").b, rel=0.01)


def test_finger_calibration_on_the_simulated_display():
    from telethermo.offline.calibration import calibrate_finger_offline

    cal, rec = calibrate_finger_offline(presets_C=(28.0, 38.0, 29.0, 37.0))
    assert cal.n_touches == 4
    # eq. 1 explains the four touches to < 0.15 °C with one beta_pad (the pad with its current held)
    assert cal.residual_C < 0.15
    assert 2.0 < cal.beta_pad < 4.0
    # the contact temperatures came from measured signals at detected contacts
    assert np.nanmax(rec.col("m_contact")) == 1.0
