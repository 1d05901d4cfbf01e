"""No drift (issue 11): after the finger is lifted and with the probe in air, both pads settle at neutral and
stay there (a real-time run after a scene's end was once seen climbing to 42 °C with nothing touching)."""

import numpy as np
import pytest

from telethermo.control.params import default_params
from telethermo.control.types import Role
from telethermo.offline import run_offline_session

pytestmark = pytest.mark.slow


def test_pads_in_air_stay_at_neutral_offline():
    res = run_offline_session("finger_lifted", duration_s=120.0)  # the lift is at 5 s
    rec = res.recording
    t = rec.col("t_s")
    neutral = default_params(Role.MASTER).safety.neutral_C
    after = t >= 15.0
    for side in ("m", "s"):
        T = rec.col(f"{side}_T_sensor_C")[after]
        assert np.max(np.abs(T - neutral)) <= 1.0, side
        # settled, not creeping: the last minute moves less than 0.1 °C
        last = rec.col(f"{side}_T_sensor_C")[t >= 60.0]
        assert np.ptp(last) <= 0.1 + 6 * 0.02, side  # + the sensor noise band
    assert res.figures["safety"]["n_trips"] == 0
