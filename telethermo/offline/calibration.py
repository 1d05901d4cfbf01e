"""Per-user finger calibration on the display (yamamoto's conclusion), offline on a simulated rig.

The pad is pre-set at known temperatures T_pad0 (two or more, on either side of the finger); at each
touch the controller holds its current, so the pad surface responds naturally; the contact
temperature T_c is the mean of the controller's own surface estimate 0.1-1 s after the *detected*
contact (measured signals only); the finger's temperature before each touch is read as yamamoto's
radiation thermometer would (here: the simulated skin ``thermometer_lead_s`` before the touch).
:func:`telethermo.control.rendering.calibrate_finger` then fits the pad's effective β relative to
this finger (eq. 1).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from telethermo.control.rendering import FingerCalibration, calibrate_finger
from telethermo.offline.figures import EARLY_S
from telethermo.recording.format import Recording
from telethermo.offline.runner import run_offline_session


def contact_temperatures_from_recording(
    rec: Recording, window_s: tuple[float, float] = EARLY_S
) -> list[float]:
    """Mean of the master's estimate over ``window_s`` after each detected contact onset, °C."""
    t = rec.col("t_s")
    c = np.nan_to_num(rec.col("m_contact")) > 0.5
    est = rec.col("m_estimate_C")
    onsets = np.flatnonzero(c[1:] & ~c[:-1]) + 1
    out = []
    for k in onsets:
        m = (t >= t[k] + window_s[0] - 1e-9) & (t < t[k] + window_s[1] - 1e-9) & c
        if m.any():
            out.append(float(np.mean(est[m])))
    return out


def calibrate_finger_offline(
    scene: Any = "virtual_materials",
    presets_C: tuple[float, ...] = (28.0, 38.0, 29.0, 37.0),
    *,
    params=None,
    seed: int | None = 0,
    beta_pad_guess: float = 2.23,
    thermometer_lead_s: float = 1.0,
) -> tuple[FingerCalibration, Recording]:
    """Run a calibration session on ``scene``'s touches and fit (β_pad, T_finger0)."""
    res = run_offline_session(
        scene,
        master_params=params,
        seed=seed,
        mode="render",
        render_options=dict(
            calibration_presets_C=list(presets_C), beta_pad=beta_pad_guess, finger_thermometer=False
        ),
    )
    rec = res.recording
    Tc = contact_temperatures_from_recording(rec)
    n = min(len(Tc), len(presets_C))
    if n < 2:
        raise ValueError(f"calibrate_finger_offline: {n} contacts detected in {scene!r}; need >= 2")
    # the radiation thermometer's reading of the finger just before each touch (yamamoto §IV-A)
    t = rec.col("t_s")
    finger = rec.col("m_true_finger_C")
    Tf0 = []
    for c in rec.meta.get("contacts", [])[:n]:
        k = int(np.searchsorted(t, c["t_on_s"] - thermometer_lead_s))
        Tf0.append(float(finger[min(k, len(t) - 1)]))
    return calibrate_finger(list(presets_C[:n]), Tc[:n], T_finger0_C=Tf0), rec
