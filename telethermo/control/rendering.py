"""Virtual material rendering (yamamoto §II-III) and per-user finger calibration.

- :func:`contact_temperature`: eq. 1, T_c = (b1·T1 + b2·T2)/(b1 + b2) of two semi-infinite bodies
  in perfect contact (works with absolute effusivities b or relative ones β = b/b_finger).
- :func:`pad_preset_temperature`: eq. 7 (eq. 5 written with relative effusivities): the pad
  temperature T_pad0 to hold *before* contact so that the finger's contact temperature on the pad
  equals the one it would have on the object.
- :func:`relative_effusivity_from_profiles`: β of an object from a recorded contact: the ratio of
  the finger's surface drop to the object's surface rise (yamamoto §III-B). Exact for semi-infinite
  bodies whatever the contact resistance (both surfaces see the same flux history).
- :func:`calibrate_finger`: the per-user step the paper's conclusion asks for: from touches of the
  pad pre-set at known temperatures (current held during the touch), fit the pad's effective β
  relative to *this* finger and the finger's initial surface temperature.
- :func:`load_render_table`: the table of β (telethermo/data/render_materials.toml).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from telethermo.control.render_table import DEFAULT_RENDER_TABLE as DEFAULT_RENDER_TABLE  # re-exported
from telethermo.control.render_table import load_render_table as load_render_table  # re-exported


def contact_temperature(T1_C: float, b1: float, T2_C: float, b2: float) -> float:
    """Yamamoto eq. 1: contact temperature of two semi-infinite bodies in perfect contact, °C.

    ``b1``, ``b2``: effusivities (J/(m²·K·s^½)) or relative effusivities (same reference).
    """
    if not (b1 > 0 and b2 > 0):
        raise ValueError(f"contact_temperature: effusivities must be > 0, got {b1}, {b2}")
    return (b1 * T1_C + b2 * T2_C) / (b1 + b2)


def pad_preset_temperature(
    T_finger0_C: float, T_object0_C: float, beta_object: float, beta_pad: float
) -> float:
    """Yamamoto eq. 7: pad pre-set temperature T_pad0, °C, that renders the object at first contact.

    T_pad0 = (T_f0 + β_obj·T_obj0)(1 + β_pad) / ((1 + β_obj)·β_pad) - T_f0/β_pad
    """
    if not (beta_object > 0 and beta_pad > 0):
        raise ValueError(
            f"pad_preset_temperature: beta_object and beta_pad must be > 0, got {beta_object}, {beta_pad}"
        )
    return (T_finger0_C + beta_object * T_object0_C) * (1.0 + beta_pad) / (
        (1.0 + beta_object) * beta_pad
    ) - T_finger0_C / beta_pad


def pad_preset_temperature_abs(
    T_finger0_C: float, b_finger: float, T_object0_C: float, b_object: float, b_pad: float
) -> float:
    """Yamamoto eq. 5 (absolute effusivities), °C; equals eq. 7 with β = b/b_finger."""
    return (b_finger * T_finger0_C + b_object * T_object0_C) * (b_finger + b_pad) / (
        (b_finger + b_object) * b_pad
    ) - b_finger * T_finger0_C / b_pad


def _window_mean(t: np.ndarray, y: np.ndarray, t0: float, t1: float, what: str) -> float:
    m = (t >= t0) & (t <= t1)
    if not m.any():
        raise ValueError(f"{what}: no samples in [{t0:.3f}, {t1:.3f}] s")
    return float(np.mean(y[m]))


def relative_effusivity_from_profiles(
    t_s: ArrayLike,
    T_finger_C: ArrayLike,
    T_object_C: ArrayLike,
    t_contact_s: float,
    window_s: tuple[float, float] = (0.1, 1.0),
    pre_s: float = 0.2,
) -> float:
    """β_object = b_object/b_finger from the recorded surface temperatures of a contact.

    ``T_finger_C``: the finger's (or pad's) surface profile, ``T_object_C``: the object's surface
    profile, both sampled at ``t_s``; contact starts at ``t_contact_s``. Initial temperatures are the
    means over ``pre_s`` before contact; the drop and the rise are the means over ``window_s``
    after contact. Returns drop/rise.
    """
    t = np.asarray(t_s, float)
    f = np.asarray(T_finger_C, float)
    o = np.asarray(T_object_C, float)
    f0 = _window_mean(t, f, t_contact_s - pre_s, t_contact_s - 1e-9, "finger profile before contact")
    o0 = _window_mean(t, o, t_contact_s - pre_s, t_contact_s - 1e-9, "object profile before contact")
    fw = _window_mean(
        t, f, t_contact_s + window_s[0], t_contact_s + window_s[1], "finger profile after contact"
    )
    ow = _window_mean(
        t, o, t_contact_s + window_s[0], t_contact_s + window_s[1], "object profile after contact"
    )
    drop, rise = f0 - fw, ow - o0
    if abs(rise) < 1e-6 or drop * rise <= 0:
        raise ValueError(
            f"relative_effusivity_from_profiles: no opposite changes (drop {drop:.4g} °C, "
            f"rise {rise:.4g} °C): bodies at the same temperature or no contact"
        )
    return drop / rise


def relative_effusivity_from_contact(T_finger0_C: float, T_object0_C: float, T_contact_C: float) -> float:
    """β_object from initial temperatures and a measured contact temperature (eq. 1 inverted)."""
    rise = T_contact_C - T_object0_C
    drop = T_finger0_C - T_contact_C
    if abs(rise) < 1e-9 or drop * rise <= 0:
        raise ValueError(
            "relative_effusivity_from_contact: the contact temperature must lie strictly "
            f"between the initial temperatures (got T_f0 {T_finger0_C}, T_o0 {T_object0_C}, "
            f"T_c {T_contact_C})"
        )
    return drop / rise


@dataclass(frozen=True, slots=True)
class FingerCalibration:
    """Result of the per-user calibration.

    Attributes:
        beta_pad: the pad's effective effusivity relative to this finger (eq. 7's β_pad).
        T_finger0_C: the finger's initial surface temperature, °C.
        residual_C: RMS residual of the fit, °C (0 with two touches).
        n_touches: touches used.
    """

    beta_pad: float
    T_finger0_C: float
    residual_C: float
    n_touches: int


def calibrate_finger(
    T_pad0_C: ArrayLike, T_contact_C: ArrayLike, T_finger0_C: ArrayLike | None = None
) -> FingerCalibration:
    """Fit β_pad (and T_finger0 unless given) from touches of the pad pre-set at ``T_pad0_C``.

    Eq. 1 for each touch: T_c = (T_f0 + β_pad·T_p0)/(1 + β_pad) = a + k·T_p0 with
    k = β_pad/(1 + β_pad), a = T_f0/(1 + β_pad). Two or more touches at different T_pad0 give
    both (least squares); with ``T_finger0_C`` known (one value, or one per touch as a radiation
    thermometer gives), one touch is enough.
    """
    p = np.atleast_1d(np.asarray(T_pad0_C, float))
    c = np.atleast_1d(np.asarray(T_contact_C, float))
    if p.shape != c.shape or p.size == 0 or not (np.isfinite(p).all() and np.isfinite(c).all()):
        raise ValueError("calibrate_finger: T_pad0_C and T_contact_C must be equal-length finite sequences")
    if T_finger0_C is not None:
        f = np.broadcast_to(np.asarray(T_finger0_C, float), p.shape)
        if not np.isfinite(f).all():
            raise ValueError("calibrate_finger: T_finger0_C must be finite")
        # k·(T_p0 - T_f0) = T_c - T_f0 : least squares through the known points
        x, y = p - f, c - f
        if float(x @ x) < 1e-9:
            raise ValueError("calibrate_finger: pad pre-set equal to the finger temperature: no information")
        k = float(x @ y) / float(x @ x)
        a = float(np.mean(f)) * (1 - k)
    else:
        if p.size < 2 or float(np.ptp(p)) < 0.5:
            raise ValueError(
                "calibrate_finger: need >= 2 touches with pre-sets >= 0.5 °C apart (or give T_finger0_C)"
            )
        A = np.column_stack([np.ones_like(p), p])
        (a, k), *_ = np.linalg.lstsq(A, c, rcond=None)
        a, k = float(a), float(k)
    if not 0.0 < k < 1.0:
        raise ValueError(
            f"calibrate_finger: fitted slope {k:.3f} outside (0, 1): touches inconsistent with eq. 1"
        )
    beta = k / (1.0 - k)
    T_f0 = a / (1.0 - k)
    if T_finger0_C is not None:
        res = float(np.sqrt(np.mean((f + k * (p - f) - c) ** 2)))
    else:
        res = float(np.sqrt(np.mean((a + k * p - c) ** 2)))
    return FingerCalibration(beta_pad=beta, T_finger0_C=T_f0, residual_C=res, n_touches=int(p.size))
