"""The settings of the identification experiment (:mod:`telethermo.ident.experiment`) and of the
capacity experiment (:mod:`telethermo.ident.capacity_experiment`), validated on construction."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

from telethermo.ident.plan import IdentifyPlan

#: progress callback: (steps done, steps in all)
Progress = Callable[[int, int], None]


@dataclass(frozen=True)
class ExperimentSettings:
    """Settings of the identification experiment (defaults: guiatni §3.3 at 10 ms, on our default rig).

    Attributes:
        rest_samples: samples at zero current before the PRBS (reference temperature).
        amplitude_A: range of the PRBS bit amplitudes, A.
        hold_samples: PRBS clock divider, samples per bit.
        current_limit_fraction: |I| <= this x rig.I_max_A (safety envelope: 0.8).
        T_min_C, T_max_C: safety envelope of the pad, °C; margin_C: guard distance to it, °C.
        flux_orders: (n, m) of the heat-flux ARMA model (eq. 12).
        flux_with_current: give the flux model the current terms (see telethermo.ident.flux).
        capacity_points: N steady states for the capacity model (guiatni: 14).
        capacity_current_span_A: the currents are spread over this span (guiatni: ±1.5 A) **clipped to
            the currents whose steady state stays inside the safety envelope** (see
            :func:`~telethermo.ident.capacity_experiment.capacity_currents`), A.
        settle_s, settle_step_s: settling time per steady state and the step it is advanced by, s
            (a simulated rig may take long steps: its integrator is exact for a held current).
        average_samples: samples averaged (at the rig's period) per steady state.
    """

    rest_samples: int = 200
    amplitude_A: tuple[float, float] = (0.1, 1.0)
    hold_samples: int = 25
    current_limit_fraction: float = 0.8
    T_min_C: float = 15.0
    T_max_C: float = 43.0
    margin_C: float = 1.0
    flux_orders: tuple[int, int] = (3, 3)
    flux_with_current: bool = True
    capacity_points: int = 14
    capacity_current_span_A: tuple[float, float] = (-1.5, 1.5)
    settle_s: float = 2000.0
    settle_step_s: float = 50.0
    average_samples: int = 300

    def plan(self, *, seed: int, train_samples: int, validation_samples: int) -> IdentifyPlan:
        """The experiment of these settings as an :class:`~telethermo.ident.plan.IdentifyPlan`."""
        return IdentifyPlan(
            seed=seed,
            rest_samples=self.rest_samples,
            train_samples=train_samples,
            validation_samples=validation_samples,
            amplitude_A=self.amplitude_A,
            hold_samples=self.hold_samples,
            margin_C=self.margin_C,
        )

    def __post_init__(self) -> None:
        def bad(name: str, expected: str) -> ValueError:
            return ValueError(f"ExperimentSettings.{name}: expected {expected}, got {getattr(self, name)!r}")

        for name, lo in (
            ("rest_samples", 0),
            ("hold_samples", 1),
            ("capacity_points", 5),
            ("average_samples", 1),
        ):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < lo:
                raise bad(name, f"an integer >= {lo}")
        a_lo, a_hi = self.amplitude_A
        if not (0.0 <= a_lo <= a_hi and math.isfinite(a_hi)):
            raise bad("amplitude_A", "(a_min, a_max) with 0 <= a_min <= a_max, A")
        if not 0.0 < self.current_limit_fraction <= 1.0:
            raise bad("current_limit_fraction", "a fraction in (0, 1]")
        if not (self.T_min_C + 2 * self.margin_C < self.T_max_C and self.margin_C >= 0.0):
            raise bad("T_max_C", "T_min_C + 2·margin_C < T_max_C with margin_C >= 0, °C")
        if not (self.settle_s > 0.0 and self.settle_step_s > 0.0):
            raise bad("settle_s", "positive settle_s and settle_step_s, s")
        c_lo, c_hi = self.capacity_current_span_A
        if not c_lo <= 0.0 <= c_hi:
            raise bad("capacity_current_span_A", "(lo, hi) with lo <= 0 <= hi, A")
