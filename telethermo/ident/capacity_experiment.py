"""The capacity experiment on a simulated rig (guiatni §3.2): N steady states at currents the
identified temperature model predicts safe, then eq. 13 fitted by least squares."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from telethermo.ident.capacity import CapacityModel, fit_capacity
from telethermo.ident.experiment_settings import ExperimentSettings, Progress
from telethermo.ident.narma import NarmaModel
from telethermo.rig import Rig


def capacity_currents(
    model: NarmaModel, *, settings: ExperimentSettings = ExperimentSettings(), I_max_A: float = math.inf
) -> np.ndarray:
    """The N currents of the capacity experiment, A: evenly spread over the widest interval around 0
    inside ``settings.capacity_current_span_A`` and ±current_limit_fraction·I_max_A whose steady state,
    as predicted by the identified temperature model, stays inside the safety envelope with its margin
    (then 10 % back from that edge).

    (On a pad in air ±1.5 A would settle far outside [15, 43] °C: 167 °C at +1.5 A on the default
    simulated rig.) Raises ValueError if no interval around 0 is safe.
    """
    lo_span, hi_span = settings.capacity_current_span_A
    lim = settings.current_limit_fraction * I_max_A
    lo_span, hi_span = max(lo_span, -lim), min(hi_span, lim)
    t_lo, t_hi = settings.T_min_C + settings.margin_C, settings.T_max_C - settings.margin_C
    grid_hi = np.linspace(0.0, hi_span, 301)
    grid_lo = np.linspace(0.0, lo_span, 301)

    def reach(grid: np.ndarray) -> float:
        Tss = model.steady_state_C(grid)
        ok = (Tss >= t_lo) & (Tss <= t_hi) & np.isfinite(Tss)
        if not ok[0]:
            raise ValueError(
                f"the rest temperature {float(Tss[0]):.2f} °C is outside the envelope [{t_lo}, {t_hi}] °C"
            )
        bad = np.flatnonzero(~ok)
        return float(grid[bad[0] - 1]) if bad.size else float(grid[-1])

    # 10 % back from the predicted edge: the model's steady state is an extrapolation in T
    return np.linspace(0.9 * reach(grid_lo), 0.9 * reach(grid_hi), settings.capacity_points)


@dataclass
class SteadyStates:
    """Steady states of a rig: current (A), sensor temperature (°C), heat flux (W), sink temperature
    (°C) and, on a simulated rig, the true flux (W); ``skipped`` lists currents dropped by the safety
    guard."""

    current_A: np.ndarray
    T_C: np.ndarray
    Q_W: np.ndarray
    T_sink_C: np.ndarray
    Q_true_W: np.ndarray
    skipped: list[float] = field(default_factory=list)


def steady_state_points(
    rig: Rig,
    currents_A: np.ndarray,
    *,
    settings: ExperimentSettings = ExperimentSettings(),
    progress: Progress | None = None,
) -> SteadyStates:
    """Hold each current until steady state (``settle_s``), then average ``average_samples`` samples.

    The safety guard checks the sensor temperature after every settling step; a current whose
    settling leaves the envelope (with margin) is cut to 0 and skipped (listed in ``skipped``).
    """
    if not hasattr(rig, "advance"):
        raise TypeError("steady_state_points drives simulated rigs (rig.advance)")
    lo, hi = settings.T_min_C + settings.margin_C, settings.T_max_C - settings.margin_C
    truth = getattr(rig, "truth", None)
    rows, skipped = [], []
    n_steps = max(1, int(math.ceil(settings.settle_s / settings.settle_step_s)))
    for idx, I in enumerate(np.asarray(currents_A, dtype=float)):
        rig.apply_current(float(I))
        safe = True
        for _ in range(n_steps):
            rig.advance(settings.settle_s / n_steps)
            T = rig.read().T_sensor_C
            if not (lo <= T <= hi):
                safe = False
                break
        if not safe:
            rig.apply_current(0.0)
            skipped.append(float(I))
            for _ in range(n_steps):
                rig.advance(settings.settle_s / n_steps)
            continue
        acc = np.zeros(4)
        for _ in range(settings.average_samples):
            rig.advance(float(rig.period_s))
            smp = rig.read()
            acc += (
                smp.T_sensor_C,
                smp.Q_W,
                smp.T_sink_C,
                truth().Q_true_W if truth is not None else math.nan,
            )
        rows.append((float(I), *(acc / settings.average_samples)))
        if progress is not None:
            progress(idx + 1, len(currents_A))
    rig.apply_current(0.0)
    arr = np.array(rows, dtype=float).reshape(-1, 5)
    return SteadyStates(arr[:, 0], arr[:, 1], arr[:, 2], arr[:, 3], arr[:, 4], skipped)


def identify_capacity(
    rig: Rig,
    model: NarmaModel,
    *,
    settings: ExperimentSettings = ExperimentSettings(),
    progress: Progress | None = None,
) -> tuple[CapacityModel, SteadyStates]:
    """The capacity experiment (guiatni §3.2): N steady states at currents from :func:`capacity_currents`,
    then eq. 13 fitted by least squares. P = the measured heat out of the pad (Q_W)."""
    currents = capacity_currents(model, settings=settings, I_max_A=float(rig.I_max_A))
    ss = steady_state_points(rig, currents, settings=settings, progress=progress)
    cap = fit_capacity(current_A=ss.current_A, T_C=ss.T_C, P_W=ss.Q_W)
    m = dict(cap.metrics)
    m.update(
        {
            "skipped_currents_A": ss.skipped,
            "settle_s": settings.settle_s,
            "average_samples": settings.average_samples,
        }
    )
    object.__setattr__(cap, "metrics", m)
    return cap, ss
