"""Material identification inside the control core: collect each touch's first samples, fit once, keep the result.

The slave's core calls :func:`material_step` every cycle with the sample and its contact decision. While
nothing touches, the last ``pre_s`` of samples are kept; from the first contact sample on, ``window_s`` of
samples are collected, then :func:`telethermo.control.material_id.estimate_effusivity` runs once and the
result (effusivity, standard error of ln b, class) is held until the next touch completes its window (a
release clears nothing: the operator may ask what was touched last). Pure: the state is an immutable value.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

from telethermo.control.material_id import ProbeParams, classify, estimate_effusivity, load_effusivity_table
from telethermo.control.rendering import load_render_table

#: the finger reference of the rendering table's β = b/b_skin for the simulator's materials, W·s^½/(m²·K)
#: (sim/data/materials.toml [materials.skin]: √(0.21 · 1200 · 3590); telethermo/data/render_materials.toml)
B_SKIN_REF = 951.15


@dataclass(frozen=True, slots=True)
class MaterialEstimate:
    """The last identified material.

    Attributes:
        effusivity: W·s^½/(m²·K) (NaN: no estimate: too few or non-finite samples, no information).
        se_ln_b: standard error of ln b (≈ relative error of the effusivity; NaN without an estimate).
        code: the material's position in the rendering table (1-based, the OD's material code), 0: none.
        posterior: the class's posterior probability (0 without an estimate).
        touch: how many touches have been evaluated (counts also those without an estimate).
        T_object0_C: the object's initial temperature the same fit gives, °C (NaN without an estimate).
    """

    effusivity: float = math.nan
    se_ln_b: float = math.nan
    code: int = 0
    posterior: float = 0.0
    touch: int = 0
    T_object0_C: float = math.nan

    @property
    def beta(self) -> float:
        """Relative effusivity b/b_skin (the rendering table's and the OD's material_beta scale)."""
        return self.effusivity / B_SKIN_REF


@dataclass(frozen=True, slots=True)
class MaterialIdParams:
    """Settings of the identification.

    Attributes:
        probe: the estimator's probe model (:class:`ProbeParams`).
        classes: (code, name, effusivity) of the rendering table's entries with an effusivity.
    """

    probe: ProbeParams = field(default_factory=ProbeParams)
    classes: tuple[tuple[int, str, float], ...] = field(default_factory=lambda: default_classes())


@functools.lru_cache(maxsize=1)
def default_classes() -> tuple[tuple[int, str, float], ...]:
    """(code, name, effusivity) of the default rendering table (code = 1-based position in the file)."""
    codes = {name: i + 1 for i, name in enumerate(load_render_table())}
    return tuple((codes[n], n, b) for n, b in load_effusivity_table().items())


@dataclass(frozen=True, slots=True)
class MaterialState:
    """Collector: ``pre`` the last pre-contact (T_sensor_C, Q_W) samples, ``post`` those since the touch,
    ``done`` the touch's window was evaluated, ``last`` the held result."""

    pre: tuple = ()
    post: tuple = ()
    done: bool = False
    last: MaterialEstimate = field(default_factory=MaterialEstimate)


def material_step(p: MaterialIdParams, st: MaterialState, T_sensor_C: float, Q_W: float, contact: bool,
                  dt_s: float) -> MaterialState:
    """Advance the collector by one sample (pure)."""
    n_pre = max(1, int(round(p.probe.pre_s / dt_s)))
    n_win = int(round(p.probe.window_s / dt_s))
    x = (float(T_sensor_C), float(Q_W))
    if not contact:
        return MaterialState(pre=(st.pre + (x,))[-n_pre:], last=st.last)
    if st.done:
        return st
    post = st.post + (x,)
    if len(post) < n_win:
        return MaterialState(pre=st.pre, post=post, last=st.last)
    rows = st.pre + post
    est = estimate_effusivity([r[0] for r in rows], [r[1] for r in rows], len(st.pre), dt_s, p.probe)
    n = st.last.touch + 1
    if est is None or not p.classes:
        return MaterialState(pre=st.pre, done=True, last=MaterialEstimate(touch=n))
    table = {name: b for _, name, b in p.classes}
    c = classify(est, table, p.probe.floor_ln)
    code = p.classes[c.index - 1][0]
    return MaterialState(pre=st.pre, done=True, last=MaterialEstimate(est.b, est.se_ln_b, code, c.posterior, n,
                                                                               est.T_object0_C))
