"""A bound on the probe's flux-loop gains from the identified model and the exchange's delay (issue 22).

An experiment's rule (bench/envelope_probe_flux.py ``--bound delay``), not used by the shipped controller.

**The loop.** The slave's flux loop drives its current I towards the mirror of the display's flux,
eQ = −Q_peer − Q. Its slow path runs through the exchange: I moves the probe's pad temperature through the
identified plant G(f) (°C/A, :func:`telethermo.control.gain_rule.linear_plant`), the display tracks that
temperature with its own loop, the finger's flux changes by K_f (W/K, the finger's contact conductance) and
comes back a transport delay later. Its loop gain is L(f) = kpQ · K_f · G(f) · D(f) · PI(f) with

- D(f): the round trip 2·(d + T) (the one-way delay d the node measures, one cycle T of the exchange each
  way) and the display's tracking lag τ_disp = 1/(2π·f_c,disp), i.e. a phase −360°·f·T_loop with
  T_loop = 2·(d + T) + τ_disp. The gain rule puts every display's crossover at the reference's
  (ρ normalises the loop gain there), so f_c,disp is the shipped master's on the reference model;
- PI(f) = 1 + f_z/(j·f): the zero f_z = kiQ/(2π·kpQ) costs atan(f_z/f_c) at the crossover. It is put a
  decade below the crossover (:data:`ZERO_BELOW_CROSSOVER`, 5.7°): the candidate's zero (0.43/0.258 A/W·s
  per A/W, 0.27 Hz) lies *above* any crossover the pad allows, so that on the free-pad model (an integrator
  from 0.05 to 0.5 Hz) the candidate's loop has at most ≈ 22° of phase at any crossover even without delay.

**Bound.** The crossover f_c is the highest frequency where the loop's phase leaves the margin:
∠G(f_c) − 360°·f_c·T_loop − atan(f_z/f_c) ≥ −180° + :data:`PHASE_MARGIN_DEG`; kpQ then makes |L(f_c)| = 1:
kpQ = 1/(K_f·|G(f_c)|). K_f is not known to the node (it is the operator's finger), so it is eliminated by
the reference: the candidate's kpQ_ref was chosen on the shipped module with no added delay, and is taken to
cross there at the margin, so K_f = 1/(kpQ_ref·|G_ref(f_c,ref)|) and

    kpQ(d) = kpQ_ref · |G_ref(f_c,ref)| / |G_rig(f_c(d))|,   kiQ(d) = kpQ(d) · 2π · f_c(d) / 10.

Where G is an integrator (the pad between 0.05 and 0.5 Hz: |G|·f constant), kpQ falls with f_c, a little
slower than 1/T_loop (the pad's own lag beyond 90° takes a share of the phase that does not grow with the
delay); a module pumping twice the heat per ampere halves it. The result is never above the reference scaled
like the other gains (ρ·kpQ_ref), so the gain rule's back-off stays in force. Limits: the finger's K_f is a
constant only to first order (a semi-infinite skin's conductance rises as √f); the probe's own path (its
flux into the object, no delay) is not in the bound; the reference's kpQ is assumed to sit at the margin.

Pure functions: models and numbers in, numbers out.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from telethermo.control.defaults import GAINS
from telethermo.control.gain_rule import LinearPlant, margins
from telethermo.control.types import Role

#: phase the flux loop keeps at its crossover, degrees
PHASE_MARGIN_DEG = 45.0
#: the flux PI's zero lies this factor below the crossover (its phase there: atan(0.1) = 5.7°)
ZERO_BELOW_CROSSOVER = 10.0


def display_crossover_Hz(ref_plant: LinearPlant) -> float:
    """The shipped master's temperature-loop crossover on the reference model, Hz (where the gain rule puts
    every identified display's)."""
    g = GAINS[Role.MASTER]
    return float(margins(ref_plant, g["kp_A_per_C"], g["ki_A_per_C_s"])["crossover_Hz"])


def loop_lag_s(one_way_delay_s: float, period_s: float, display_crossover_Hz: float) -> float:
    """T_loop of the flux loop through the exchange, s: the round trip 2·(d + T) and the display's lag.

    >>> round(loop_lag_s(0.05, 0.01, 1.0), 4)
    0.2792
    """
    if one_way_delay_s < 0 or period_s <= 0 or display_crossover_Hz <= 0:
        raise ValueError("loop_lag_s needs a delay >= 0 s, a period > 0 s and a display crossover > 0 Hz")
    return 2.0 * (one_way_delay_s + period_s) + 1.0 / (2.0 * math.pi * display_crossover_Hz)


def delay_crossover_Hz(
    plant: LinearPlant,
    loop_lag: float,
    *,
    zero_Hz: float = 0.0,
    zero_ratio: float = 0.0,
    phase_margin_deg: float = PHASE_MARGIN_DEG,
) -> float:
    """The highest frequency f (Hz; below the first one above the phase's peak where it fails) at which
    the flux loop's phase, ∠G(f) − 360°·f·loop_lag − atan(zero_Hz/f + zero_ratio) (the PI's zero: fixed
    at ``zero_Hz``, or at ``zero_ratio`` times f), stays at or above −180° + ``phase_margin_deg``."""
    f = np.logspace(-3, math.log10(0.499 / plant.period_s), 4000)
    ph = (
        np.degrees(np.unwrap(np.angle(plant.response(f))))
        - 360.0 * f * loop_lag
        - np.degrees(np.arctan(zero_Hz / f + zero_ratio))
    )
    top = int(np.argmax(ph))  # a PI's phase rises from −90° before the plant's lag takes over
    bad = top + np.nonzero(ph[top:] < -180.0 + phase_margin_deg)[0]
    return float(f[max(int(bad[0]) - 1, top)]) if len(bad) else float(f[-1])


def flux_gain_bound(
    rig_plant: LinearPlant,
    ref_plant: LinearPlant,
    one_way_delay_s: float,
    kpQ_ref_A_per_W: float,
    rho: float = 1.0,
) -> dict[str, Any]:
    """The flux loop's gains for the rig of ``rig_plant`` at the measured one-way delay (module docstring):
    ``kpQ_A_per_W``, ``kiQ_A_per_W_s``, with the crossovers (Hz) and loop lags (s) they were set from."""
    if kpQ_ref_A_per_W <= 0:
        raise ValueError(f"flux_gain_bound needs kpQ_ref_A_per_W > 0 A/W, got {kpQ_ref_A_per_W}")
    T = rig_plant.period_s
    f_disp = display_crossover_Hz(ref_plant)
    zero_ratio = 1.0 / ZERO_BELOW_CROSSOVER
    lag_ref = loop_lag_s(0.0, ref_plant.period_s, f_disp)
    fc_ref = delay_crossover_Hz(ref_plant, lag_ref, zero_ratio=zero_ratio)
    lag = loop_lag_s(one_way_delay_s, T, f_disp)
    fc = delay_crossover_Hz(rig_plant, lag, zero_ratio=zero_ratio)
    g_ref = float(np.abs(ref_plant.response(fc_ref)))
    g_rig = max(float(np.abs(rig_plant.response(fc))), 1e-12)
    kpQ = min(kpQ_ref_A_per_W * g_ref / g_rig, rho * kpQ_ref_A_per_W)
    return {
        "kpQ_A_per_W": kpQ,
        "kiQ_A_per_W_s": kpQ * 2.0 * math.pi * fc * zero_ratio,
        "crossover_Hz": fc,
        "reference_crossover_Hz": fc_ref,
        "loop_lag_s": lag,
        "reference_loop_lag_s": lag_ref,
        "display_crossover_Hz": f_disp,
    }
