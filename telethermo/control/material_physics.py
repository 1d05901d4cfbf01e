"""Physics-first identification anywhere in the envelope (issue 23): a posterior over the table's materials
from the physics fit's effusivity, with the object's temperature and the direction of the heat flow as inputs.

The physics fit (telethermo.control.material_id) measures the object's effusivity b and initial temperature
T_o0 from the probe's own filtered T_sensor and Q, whatever the sign of the heat flow: its relation
E = b·A·I½[T_os − T_o0] holds for an object hotter than the probe (E < 0, T_os − T_o0 < 0, b > 0) as for a
colder one, and it does not involve the TEM or the controller (the probe's sensor alone, ProbeParams). It is
biased by its own lumped sensor model, most on metals behind a contact resistance and on thin slabs, far
beyond its standard error se_ln_b. So each table material m gets the likelihood

    L_m = (1 − ε)·N(ln b_fit; ln b_m, σ) + ε / W,   σ² = (k·se_ln_b)² + f²,

a Gaussian of the fit's own uncertainty inflated by a calibrated factor ``k`` and a model floor ``f``, plus an
outlier share ``ε`` spread over W = 12 in ln b (the fit's heavy tail: a metal read as an insulator), and the
posterior is L_m normalised (equal priors). The published effusivity interval is b·exp(±1.96·σ_ci) with
σ_ci² = (k_ci·se_ln_b)² + f_ci², whose factor and floor were fitted on the same calibration touches for its
coverage. All constants (:data:`EARLY`, :data:`LATE`) are measured by
``python -m bench.material_physics_calibrate`` on 600 envelope touches of their own seeds (draw 3131,
simulator 1200000 + i), disjoint from every evaluation, on the shipped probe.

A lab's own probe (another sensor, another bias) is calibrated by ``telethermo calibrate-material``
(telethermo.control.material_lab): its correction ln b_fit -> offset_ln + scale·ln b_fit (se_ln_b × scale)
is applied by :meth:`PhysicsCalibration.corrected` before the likelihood and the published interval, with
its own floors. The defaults (offset 0, scale 1) leave every figure unchanged to the last digit.

Abstains, only where the physics cannot tell (:func:`decide`): no fit; a fitted |T_probe − T_o0| below
:data:`MIN_DT_C` (the object draws almost no heat); a posterior below :data:`MIN_POSTERIOR`. Pure.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import cast

import numpy as np

from telethermo.control.material_id import EffusivityEstimate

#: the smallest fitted |probe − object| temperature difference still named, °C
MIN_DT_C = 2.0
#: the smallest posterior still named (twice the chance of ten materials)
MIN_POSTERIOR = 0.2
#: the outlier share's width in ln b
OUTLIER_WIDTH_LN = 12.0


@dataclass(frozen=True, slots=True)
class PhysicsCalibration:
    """How far the physics fit's ln b is from the truth (module docstring).

    Attributes:
        window_s: the fit window it was measured for, s.
        k: factor on se_ln_b in the likelihood; floor_ln: its model floor in ln b; outlier: ε.
        k_ci, floor_ci_ln: the same for the published 95 % interval (its coverage fitted).
        offset_ln, scale: a lab's correction of the fit, ln b = offset_ln + scale·ln b_fit (default: none).
    """

    window_s: float
    k: float
    floor_ln: float
    outlier: float
    k_ci: float
    floor_ci_ln: float
    offset_ln: float = 0.0
    scale: float = 1.0

    def corrected(self, est: EffusivityEstimate | None) -> EffusivityEstimate | None:
        """The fit ``est`` through the lab's correction (b and se_ln_b; ``est`` itself without one)."""
        if est is None or (self.offset_ln == 0.0 and self.scale == 1.0):
            return est
        ln_b = self.offset_ln + self.scale * math.log(est.b) if est.b > 0 else math.nan
        return replace(est, b=math.exp(ln_b), se_ln_b=self.scale * est.se_ln_b)

    def sigma_ci(self, se_ln_b: float) -> float:
        """The calibrated standard error of ln b of the published interval (dimensionless)."""
        return math.hypot(self.k_ci * se_ln_b, self.floor_ci_ln)


#: the early answer's (0.3 s window) and the refined answer's (1.2 s window) calibration
EARLY = PhysicsCalibration(window_s=0.3, k=2.0, floor_ln=0.3, outlier=0.5, k_ci=2.0, floor_ci_ln=1.3)
LATE = PhysicsCalibration(window_s=1.2, k=4.0, floor_ln=0.4, outlier=0.3, k_ci=6.0, floor_ci_ln=0.8)


def posterior(est: EffusivityEstimate, ln_b_table: np.ndarray, cal: PhysicsCalibration) -> np.ndarray:
    """Posterior of each material (``ln_b_table``: their ln effusivity) given the fit ``est`` (already
    through ``cal``'s lab correction, :meth:`PhysicsCalibration.corrected`)."""
    sig = math.hypot(cal.k * est.se_ln_b, cal.floor_ln)
    g = np.exp(-0.5 * ((math.log(est.b) - ln_b_table) / sig) ** 2) / (sig * math.sqrt(2.0 * math.pi))
    lik = (1.0 - cal.outlier) * g + cal.outlier / OUTLIER_WIDTH_LN
    return cast(np.ndarray, lik / lik.sum())


def decide(
    est: EffusivityEstimate | None, T_probe_C: float, ln_b_table: np.ndarray, cal: PhysicsCalibration
) -> tuple[int, float, str]:
    """(0-based index of the likeliest material or −1, its posterior, why abstained or "") for fit ``est`` of
    a touch by a probe resting at ``T_probe_C`` °C (the pre-contact mean), via ``cal``'s lab correction."""
    est = cal.corrected(est)
    if est is None or not (math.isfinite(est.b) and est.b > 0 and math.isfinite(est.T_object0_C)):
        return -1, 0.0, "no_fit"
    if abs(T_probe_C - est.T_object0_C) < MIN_DT_C:
        return -1, 0.0, "weak_evidence"
    post = posterior(est, ln_b_table, cal)
    i = int(np.argmax(post))
    if post[i] < MIN_POSTERIOR:
        return -1, float(post[i]), "low_posterior"
    return i, float(post[i]), ""
