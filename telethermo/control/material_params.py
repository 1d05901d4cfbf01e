"""The material identification's settings (:class:`MaterialIdParams`), what it publishes
(:class:`MaterialEstimate`) and when: the early and the refined answer's windows and the cycles of fit work
after each (telethermo.control.material_stream runs it)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import cast

from telethermo.control import material_physics as mp
from telethermo.control.material_calib import (
    ENVELOPE_EARLY,
    ENVELOPE_LATE,
    ENVELOPE_POOL,
    Calibration,
    n_units,
)
from telethermo.control.material_defaults import default_calibration, default_classes, default_envelope
from telethermo.control.material_id import FORMS, ProbeParams, noise_draws
from telethermo.control.material_trust import CalibrationBox

#: the finger reference of the rendering table's β = b/b_skin for the simulator's materials, W·s^½/(m²·K)
#: (sim/data/materials.toml [materials.skin]: √(0.21 · 1200 · 3590); telethermo/data/render_materials.toml)
B_SKIN_REF = 951.15
#: the published code of an abstention ("unknown"): the touch lies outside what the classifier was
#: calibrated on, or its evidence is weak; the effusivity and object temperature the physics fit measured
#: are still published
UNKNOWN_CODE = 255
#: units of the physics fit run per control cycle (the window's signals, the two forms, the noise
#: realisations: about 0.08 ms each here); a network layer ends its cycle (in the vcan VM's software
#: emulation one layer takes up to 6 ms of a 10 ms cycle). Three put the early answer 7 cycles after its
#: window, not 15, so that window can be 0.42 s and the answer still come 0.49 s after the contact (the early
#: envelope classifier gains with every sample: docs/material_id.md)
UNITS_PER_CYCLE = 3


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
        abstained: why the answer is "unknown" (code :data:`UNKNOWN_CODE`; telethermo.control.material_physics
            .decide), "" when it named a material.
        early_code, early_posterior: the first answer (0.3 s window, the envelope classifier's 0.42 s; the
            network in its box, else the physics posterior), kept when the refined one (``stage`` "late", the
            physics fit over 1.2 s) replaces ``code`` and ``posterior``.
        stage: "early" or "late" (the answer in ``code``), "" without an answer.
        by: "network" (the calibrated classifier in its box: the refined answer keeps its class and posterior,
            the late fit refines the effusivity only) or "physics" (telethermo.control.material_physics).
    """

    effusivity: float = math.nan
    se_ln_b: float = math.nan
    code: int = 0
    posterior: float = 0.0
    touch: int = 0
    T_object0_C: float = math.nan
    abstained: str = ""
    early_code: int = 0
    early_posterior: float = 0.0
    stage: str = ""
    by: str = ""

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
        calibration: the calibrated classifier (default: the shipped file,
            telethermo/data/material_classifier.npz, loaded once); None: the nearest table effusivity of the
            physics fit. Used only when its period and window are the core's (:func:`calibrated`); its
            materials must be among ``classes``.
        box: what the calibration was measured on; a touch outside it is named by the physics posterior
            (telethermo.control.material_physics) instead of the network; None: the network always names it.
        early, late: the physics posterior's calibration of the early (0.3 s) and refined answer (1.2 s of
            contact; ``late`` None: no refined answer).
        units_per_cycle: units of the physics fit run in one control cycle (:data:`UNITS_PER_CYCLE`; a network
            layer ends its cycle).
        envelope, envelope_late: the envelope classifiers of the early and the refined answer (default: the
            shipped files, telethermo/data/material_envelope_*.npz; telethermo.offline.material_envelope_refs
            says what they were trained on): they name a touch outside ``box`` in place of the physics
            posterior, where they apply (:func:`applies`); None: the physics posterior. ``envelope_pool``:
            the early classifier (0.3 s) the refined answer pools with (its pool was fitted with it).
    """

    probe: ProbeParams = field(default_factory=ProbeParams)
    classes: tuple[tuple[int, str, float], ...] = field(default_factory=lambda: default_classes())
    calibration: Calibration | None = field(default_factory=lambda: default_calibration())
    box: CalibrationBox | None = field(default_factory=CalibrationBox)
    early: mp.PhysicsCalibration = mp.EARLY
    late: mp.PhysicsCalibration | None = mp.LATE
    envelope: Calibration | None = field(default_factory=lambda: default_envelope(ENVELOPE_EARLY))
    envelope_late: Calibration | None = field(default_factory=lambda: default_envelope(ENVELOPE_LATE))
    envelope_pool: Calibration | None = field(default_factory=lambda: default_envelope(ENVELOPE_POOL))
    units_per_cycle: int = UNITS_PER_CYCLE

    @property
    def late_window_s(self) -> float:
        """The refined answer's window, s (0: none)."""
        return self.late.window_s if self.late is not None else 0.0

    def __post_init__(self) -> None:
        if self.units_per_cycle < 1:
            raise ValueError(f"units_per_cycle must be >= 1, not {self.units_per_cycle}")
        if self.calibration is not None:
            names = {n for _, n, _ in self.classes}
            missing = [c for c in self.calibration.classes if c not in names]
            if missing:
                raise ValueError(
                    f"material classifier names {missing} that the rendering table has no effusivity for"
                )


def applies(cal: Calibration | None, window_s: float, dt_s: float) -> bool:
    """Whether classifier ``cal`` was measured at period ``dt_s`` over a window of ``window_s``."""
    n = int(round(window_s / dt_s))
    return cal is not None and abs(cal.dt_s - dt_s) <= 1e-9 and window_s > 0.0 and cal.n_win == n


def calibrated(p: MaterialIdParams, dt_s: float) -> bool:
    """Whether the calibration applies at period ``dt_s`` (measured with the same period and window)."""
    return applies(p.calibration, p.probe.window_s, dt_s)


def early_samples(p: MaterialIdParams, dt_s: float) -> int:
    """Samples after the touch the early answer waits for: the physics fit's window, or the early envelope
    classifier's when longer (0.42 s against 0.3 s: docs/material_id.md), not beyond the refined one's."""
    n, env, n_late = int(round(p.probe.window_s / dt_s)), p.envelope, late_samples(p, dt_s)
    if env is None or abs(env.dt_s - dt_s) > 1e-9 or not n <= env.n_win <= max(n_late, n):
        return n
    return env.n_win


def early_envelope(p: MaterialIdParams, dt_s: float) -> bool:
    """Whether the early envelope classifier applies at period ``dt_s`` (its window is the early answer's)."""
    return applies(p.envelope, early_samples(p, dt_s) * dt_s, dt_s)


def fit_work_units(p: MaterialIdParams, dt_s: float) -> int:
    """Units of work of an early fit: the window's signals, the energy form, the flux form, each noise
    realisation, then the classification: one layer of the calibrated networks per unit, or the nearest
    effusivity in one."""
    cal = cast(Calibration, p.calibration)  # not None when calibrated
    return physics_units(p) + (n_units(cal) if calibrated(p, dt_s) else 1)


def fit_units(p: MaterialIdParams, dt_s: float) -> int:
    """Cycles from the window's completion to the published result: the physics fit's units
    ``units_per_cycle`` a cycle, the first network layer (or the nearest effusivity) in the cycle of the last
    of them when there is room, each further layer in a cycle of its own."""
    return _cycles(physics_units(p), fit_work_units(p, dt_s) - physics_units(p), p.units_per_cycle)


def late_fit_units(p: MaterialIdParams) -> int:
    """Cycles from the refined window's completion to the refined answer when the envelope classifiers give
    it: the physics fit's units, then the pool's early network and the refined one, layer by layer."""
    nets = sum(n_units(c) for c in (p.envelope_pool, p.envelope_late) if c is not None)
    return _cycles(physics_units(p), max(nets, 1), p.units_per_cycle)


def _cycles(physics: int, nets: int, per_cycle: int) -> int:
    """Cycles of ``physics`` units ``per_cycle`` a cycle, then ``nets`` network layers, the first in the last
    physics cycle when there is room, the others one a cycle."""
    return -(-(physics + 1) // per_cycle) + nets - 1


def physics_units(p: MaterialIdParams) -> int:
    """Units of the physics fit: the window's signals, the two forms, the noise realisations."""
    return 1 + len(FORMS) + noise_draws(p.probe)


def late_samples(p: MaterialIdParams, dt_s: float) -> int:
    """Samples after the touch the refined answer's fit uses (0: no refined answer)."""
    if p.late is None:
        return 0
    n = int(round(p.late.window_s / dt_s))
    return n if n > int(round(p.probe.window_s / dt_s)) else 0
