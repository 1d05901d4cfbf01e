"""Later-phase rendering by benali-khoudja's RC analog (§4, Table 1).

"Starting from the contact temperature value obtained from the first model" (eq. 1), the rendered
temperature relaxes with one time constant τ = R·C of the material:

    T_render(t) = T_final + (T_contact − T_final)·exp(−t/τ),
    T_final = T_finger0 + φ·(T_object0 − T_finger0)

τ and φ (the share of the initial difference left at the end: 0 = the object ends at the finger's
temperature) are identified per material, thickness, back and load from a cooling experiment like
benali-khoudja's (object heated to 40 °C, cooling in contact with the finger, with and without a 50 g
load; bench/rc_identify.py on the simulator) and stored in telethermo/data/render_rc.toml, which
:func:`load_rc_table` reads. :func:`fit_exponential` is the identification's fit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import cast

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares

from telethermo.inputfile import Section, load_toml

DEFAULT_RC_TABLE = Path(__file__).resolve().parent.parent / "data" / "render_rc.toml"
#: the keys of an [[entry]] (thickness mm, load g, tau s; fit_rms_C: the fit's residual, °C, for the record)
RC_KEYS = {"material", "thickness_mm", "back", "load_g", "tau_s", "final_fraction", "fit_rms_C"}


@dataclass(frozen=True, slots=True)
class RcEntry:
    """One identified time constant. τ in s, thickness in mm, load in g, φ dimensionless."""

    material: str
    thickness_mm: float
    back: str
    load_g: float
    tau_s: float
    final_fraction: float


def rc_temperature(T_contact_C: float, T_final_C: float, tau_s: float, t_since_s: float) -> float:
    """T_final + (T_contact − T_final)·exp(−t/τ), °C (``t_since_s``: time since the touch, s)."""
    return T_final_C + (T_contact_C - T_final_C) * math.exp(-max(t_since_s, 0.0) / tau_s)


def fit_exponential(t_s: ArrayLike, T_C: ArrayLike) -> tuple[float, float, float, float]:
    """Fit T(t) = T_inf + (T_0 − T_inf)·exp(−t/τ) by least squares: (τ s, T_inf °C, T_0 °C, RMS °C)."""
    t = np.asarray(t_s, float)
    y = np.asarray(T_C, float)
    if t.size < 4 or not (np.isfinite(t).all() and np.isfinite(y).all()) or np.ptp(y) <= 0:
        raise ValueError("fit_exponential: need >= 4 finite samples of a changing temperature")
    t0 = t - t[0]

    def res(p: NDArray[np.float64]) -> NDArray[np.float64]:
        tau, Tinf, T0 = p
        return cast(NDArray[np.float64], Tinf + (T0 - Tinf) * np.exp(-t0 / tau) - y)  # p's items: Any

    p0 = (max(t0[-1] / 3.0, 1e-3), y[-1], y[0])
    sol = least_squares(res, p0, bounds=([1e-4, -100.0, -100.0], [1e6, 200.0, 200.0]), x_scale="jac")
    tau, Tinf, T0 = (float(v) for v in sol.x)
    return tau, Tinf, T0, float(np.sqrt(np.mean(sol.fun**2)))


def load_rc_table(path: str | Path | None = None) -> list[RcEntry]:
    """The identified τ table ([[entry]] array of tables); errors name the file and the field."""
    path = Path(path) if path is not None else DEFAULT_RC_TABLE
    top = Section(path, "", load_toml(path, what="an RC table (TOML)"), {"entry"})
    rows = top.list("entry", expected="a non-empty array of tables [[entry]]")
    if not rows:
        raise top.fail("entry", "a non-empty array of tables [[entry]]", rows)
    out = []
    for k, raw in enumerate(rows):
        e = Section(path, f"entry[{k}]", raw, RC_KEYS)
        out.append(
            RcEntry(
                e.str("material"),
                e.float("thickness_mm", positive=True),
                e.str("back"),
                e.float("load_g", lo=0.0),
                e.float("tau_s", positive=True, expected="a time > 0 s"),
                e.float("final_fraction"),
            )
        )
    return out


def rc_lookup(
    table: list[RcEntry], material: str, thickness_mm: float, back: str = "adiabatic", load_g: float = 0.0
) -> tuple[float, float]:
    """(τ s, φ) for an object: the entries of the same material, back and load, interpolated linearly in
    thickness (clamped to the identified range). An "ambient" back without entries falls back to the
    adiabatic ones. ValueError when the material has none."""
    for b in (back, "adiabatic"):
        rows = sorted(
            (e for e in table if e.material == material and e.back == b and abs(e.load_g - load_g) < 1e-9),
            key=lambda e: e.thickness_mm,
        )
        if rows:
            break
    else:
        raise ValueError(
            f"RC table: no time constant for {material!r} (back {back}, load {load_g} g); "
            f"materials: {', '.join(sorted({e.material for e in table}))}"
        )
    th = np.array([e.thickness_mm for e in rows])
    tau = float(np.interp(thickness_mm, th, [e.tau_s for e in rows]))
    phi = float(np.interp(thickness_mm, th, [e.final_fraction for e in rows]))
    return tau, phi
