"""A lab's calibration of the physics fit from a handful of touches of reference samples (issue 23).

The physics posterior (telethermo.control.material_physics) is TEM-independent but biased by its lumped
sensor model (telethermo.control.material_id.ProbeParams): its constants EARLY/LATE were measured on the
shipped probe. A lab's probe has another sensor (thickness, material, thermocouple depth) and so another
bias. From N touches of reference samples of known table effusivity b_m, each giving the fit's ln b_fit and
se_ln_b over the early (0.3 s) and the refined (1.2 s) window, :func:`fit_window` fits per window

    ln b_true ≈ offset_ln + scale·ln b_fit          (least squares)

and the residual floor of the likelihood and of the published interval:

- **affine** (offset and scale) with at least :data:`MIN_AFFINE_TOUCHES` touches of at least two materials
  whose table ln b span at least :data:`MIN_AFFINE_SPAN_LN`, and a fitted scale in :data:`SCALE_RANGE`: a
  sensor's bias is not one factor on b (a thicker sensor than the model's reads insulators far too high and
  metals about right, bench/material_lab_calibrate.py); else **offset** only (scale 1): one material, or
  too few touches to fit a slope and still have residuals left for the floor;
- the floors: s² = Σr²/(N − p) over the residuals r (p = 1 or 2 fitted parameters); the likelihood's floor
  f² = s² − mean((k·scale·se)²), the interval's f_ci² = q²·s²·(1 + p/N) − mean((k_ci·scale·se)²) with q the
  Student-t 97.5 % quantile of N − p degrees of freedom over 1.96 (a prediction interval: few touches
  claim a wider one), each never below the calibration it corrects (the shipped EARLY/LATE floors: the
  spread that the touch's conditions, thickness, force, contact and object temperature, add across the
  envelope, which reference touches of a few thick samples at room temperature cannot see) nor below
  :data:`MIN_FLOOR_LN` (a sample's effusivity differs from the table's handbook value by about that much):
  three touches that happen to agree cannot claim perfection. k, k_ci and the outlier share stay the
  shipped calibration's.

:func:`lab_params` puts a :class:`LabCorrection` into the identification's settings (MaterialIdParams.early
and .late, whose posterior and published interval apply it, PhysicsCalibration.corrected). The lab file
(:func:`save_lab`, :func:`load_lab`: JSON, written atomically, every error one line naming the file and the
field) is what ``telethermo calibrate-material`` writes and the slave node loads (``--material-lab``).
Pure, but for the file functions.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from scipy import stats

from telethermo.atomic import write_json_atomic
from telethermo.control import material_physics as mp
from telethermo.control.material_id import EffusivityEstimate, ProbeParams, estimate_effusivity
from telethermo.control.material_stream import MaterialIdParams
from telethermo.inputfile import InputFileError, Section, load_json

LAB_FORMAT = "telethermo.material-lab/1"
#: the smallest floor of ln b a lab file may hold, for the likelihood and the interval (fit_window also keeps
#: the floors of the calibration it corrects)
MIN_FLOOR_LN = 0.15
#: an affine correction needs this many touches (two parameters and two residuals left for the floor) ...
MIN_AFFINE_TOUCHES = 4
#: ... of materials whose table ln b span at least this much
MIN_AFFINE_SPAN_LN = 1.0
#: the scales an affine fit may give; outside them the touches do not pin a slope (offset only)
SCALE_RANGE = (0.2, 5.0)


@dataclass(frozen=True, slots=True)
class LabTouch:
    """One reference touch over one window: the physics fit's ``ln_b_fit`` and ``se_ln_b`` (dimensionless)
    and the table effusivity of the sample's material ``b_true`` (W·s^½/(m²·K)), named ``material``."""

    ln_b_fit: float
    se_ln_b: float
    b_true: float
    material: str = ""


@dataclass(frozen=True, slots=True)
class LabWindow:
    """The correction of one window's fit.

    Attributes:
        window_s: the fit window, s (0.3 early, 1.2 refined).
        offset_ln, scale: ln b = offset_ln + scale·ln b_fit.
        floor_ln, floor_ci_ln: the likelihood's and the published interval's floor in ln b.
        model: "affine" or "offset" (module docstring); why: the reason an affine fit was not used ("").
        n_touches: touches fitted; rms_before_ln, rms_after_ln: RMS of ln b_true − ln b before / after.
    """

    window_s: float
    offset_ln: float = 0.0
    scale: float = 1.0
    floor_ln: float = MIN_FLOOR_LN
    floor_ci_ln: float = MIN_FLOOR_LN
    model: str = "offset"
    why: str = ""
    n_touches: int = 0
    rms_before_ln: float = math.nan
    rms_after_ln: float = math.nan

    def ln_b(self, ln_b_fit: np.ndarray | float) -> Any:
        """The corrected ln b of the fit's ``ln_b_fit``."""
        return self.offset_ln + self.scale * np.asarray(ln_b_fit, float)

    def calibration(self, cal: mp.PhysicsCalibration) -> mp.PhysicsCalibration:
        """The physics posterior's calibration ``cal`` with this correction and its floors."""
        return replace(
            cal,
            offset_ln=self.offset_ln,
            scale=self.scale,
            floor_ln=self.floor_ln,
            floor_ci_ln=self.floor_ci_ln,
        )


@dataclass(frozen=True, slots=True)
class LabCorrection:
    """A lab's correction of the early and the refined answer's fit (``late`` None: the early one only)."""

    early: LabWindow
    late: LabWindow | None = None


def fit_window(touches: Sequence[LabTouch], window_s: float, base: mp.PhysicsCalibration) -> LabWindow:
    """The correction of one window from its reference ``touches`` (module docstring); ``base``: the
    calibration it corrects (its k, k_ci). ValueError without a touch."""
    if not touches:
        raise ValueError(f"no reference touch with a fit over the {window_s:g} s window")
    x = np.array([t.ln_b_fit for t in touches], float)
    se = np.array([t.se_ln_b for t in touches], float)
    y = np.log(np.array([t.b_true for t in touches], float))
    n = x.size
    span = float(np.ptp(y))
    offset, scale, model, why = float(np.mean(y - x)), 1.0, "offset", ""
    if n < MIN_AFFINE_TOUCHES:
        why = f"{n} touches (an affine fit needs {MIN_AFFINE_TOUCHES})"
    elif span < MIN_AFFINE_SPAN_LN:
        why = f"the materials' ln b span {span:.2f} (an affine fit needs {MIN_AFFINE_SPAN_LN})"
    else:
        c, a = np.polyfit(x, y, 1)
        if SCALE_RANGE[0] <= c <= SCALE_RANGE[1]:
            offset, scale, model = float(a), float(c), "affine"
        else:
            why = f"the fitted scale {c:.2f} lies outside {SCALE_RANGE}"
    p = 2 if model == "affine" else 1
    r = y - (offset + scale * x)
    s2 = float(np.sum(r**2)) / max(n - p, 1)
    q = float(stats.t.ppf(0.975, max(n - p, 1))) / 1.96
    floor = max(
        MIN_FLOOR_LN, base.floor_ln, math.sqrt(max(0.0, s2 - float(np.mean((base.k * scale * se) ** 2))))
    )
    ci_var = q**2 * s2 * (1.0 + p / n) - float(np.mean((base.k_ci * scale * se) ** 2))
    return LabWindow(
        window_s=window_s,
        offset_ln=offset,
        scale=scale,
        floor_ln=floor,
        floor_ci_ln=max(MIN_FLOOR_LN, base.floor_ci_ln, math.sqrt(max(0.0, ci_var))),
        model=model,
        why=why,
        n_touches=n,
        rms_before_ln=float(np.sqrt(np.mean((y - x) ** 2))),
        rms_after_ln=float(np.sqrt(np.mean(r**2))),
    )


def touch_fits(
    T_sensor_C: np.ndarray, Q_W: np.ndarray, i_contact: int, dt_s: float, windows_s: Sequence[float]
) -> list[EffusivityEstimate | None]:
    """The physics fit of one touch (the samples, period ``dt_s``, ``i_contact`` the first contact sample)
    over each window of ``windows_s``, as the slave's core fits it (None: no fit, or the samples end before
    the window)."""
    out: list[EffusivityEstimate | None] = []
    for w in windows_s:
        n_win = int(round(w / dt_s))
        if i_contact < 1 or i_contact + n_win > len(T_sensor_C):
            out.append(None)
            continue
        e = estimate_effusivity(T_sensor_C, Q_W, i_contact, dt_s, replace(ProbeParams(), window_s=w))
        ok = e is not None and math.isfinite(e.b) and e.b > 0 and math.isfinite(e.se_ln_b)
        out.append(e if ok else None)
    return out


def lab_params(p: MaterialIdParams, lab: LabCorrection | None) -> MaterialIdParams:
    """The identification's settings ``p`` with the lab's correction (``lab`` None: ``p`` itself).
    ValueError when the lab file's windows are not the settings' (it was fitted over other windows)."""
    if lab is None:
        return p
    if abs(lab.early.window_s - p.early.window_s) > 1e-9:
        raise ValueError(
            f"early.window_s: {lab.early.window_s:g} s, the slave's early window is {p.early.window_s:g} s"
        )
    late = p.late
    if lab.late is not None and late is not None:
        if abs(lab.late.window_s - late.window_s) > 1e-9:
            raise ValueError(
                f"late.window_s: {lab.late.window_s:g} s, the slave's refined window is {late.window_s:g} s"
            )
        late = lab.late.calibration(late)
    return replace(p, early=lab.early.calibration(p.early), late=late)


_WINDOW_KEYS = {
    "window_s",
    "offset_ln",
    "scale",
    "floor_ln",
    "floor_ci_ln",
    "model",
    "why",
    "n_touches",
    "rms_before_ln",
    "rms_after_ln",
}


def lab_document(lab: LabCorrection, info: dict[str, Any] | None = None) -> dict[str, Any]:
    """The lab file's JSON object (``info``: what it was fitted from, kept for the record)."""
    doc: dict[str, Any] = {"format": LAB_FORMAT}
    for name in ("early", "late"):
        w = getattr(lab, name)
        if w is not None:
            doc[name] = {k: _json_number(getattr(w, k)) for k in sorted(_WINDOW_KEYS)}
    doc["info"] = info or {}
    return doc


def _json_number(v: Any) -> Any:
    return None if isinstance(v, float) and not math.isfinite(v) else v


def save_lab(path: str | os.PathLike[str], lab: LabCorrection, info: dict[str, Any] | None = None) -> Path:
    """Write the lab file atomically."""
    return write_json_atomic(path, lab_document(lab, info))


def load_lab(path: str | os.PathLike[str]) -> LabCorrection:
    """Read a lab file; every error an InputFileError (a ValueError) of one line naming the file and field."""
    top = load_json(path, "a material lab file (telethermo calibrate-material --out)")
    top.check_keys({"format", "early", "late", "info"})
    top.str("format", choices=(LAB_FORMAT,))
    early = _window(top.table("early", _WINDOW_KEYS))
    late = _window(top.table("late", _WINDOW_KEYS)) if top.has("late") else None
    return LabCorrection(early=early, late=late)


def _window(s: Section) -> LabWindow:
    def rms(key: str) -> float:
        v = s.get(key, None)
        return math.nan if v is None else s.float(key, lo=0.0)

    w = LabWindow(
        window_s=s.float("window_s", positive=True, unit=" s"),
        offset_ln=s.float("offset_ln"),
        scale=s.float("scale", lo=SCALE_RANGE[0], hi=SCALE_RANGE[1]),
        floor_ln=s.float("floor_ln", lo=MIN_FLOOR_LN, hi=10.0),
        floor_ci_ln=s.float("floor_ci_ln", lo=MIN_FLOOR_LN, hi=10.0),
        model=s.str("model", choices=("affine", "offset")),
        why=s.str("why", "", nonempty=False),
        n_touches=s.int("n_touches", lo=1),
        rms_before_ln=rms("rms_before_ln"),
        rms_after_ln=rms("rms_after_ln"),
    )
    if w.model == "offset" and w.scale != 1.0:
        raise InputFileError.at(s.file, s.name("scale"), "1 with model offset", w.scale)
    return w
