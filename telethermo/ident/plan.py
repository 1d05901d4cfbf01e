"""The identification experiment as a plan: what current to command at each sample, and the guard that
keeps the pad inside the safety envelope while it runs.

One definition for both places the experiment runs:

- offline, on a simulated rig (:func:`telethermo.ident.experiment.identify_rig`);
- live, inside a node in IDENTIFY mode (the control core, :func:`telethermo.control.core.step`), while
  ``telethermo identify <node>`` records the samples from the bus.

So the same plan (seed, lengths, amplitudes) on the same rig gives the same currents in both.

The plan (guiatni §3.3, on a pad that touches nothing)::

    sample j:   0 .. rest-1                 0 A (the reference temperature T_ref_C of the model)
                rest .. rest+train-1        training PRBS, seed ``seed``
                .. rest+train+validation-1  held-out PRBS, seed ``seed + 1`` (never used to fit)
                total ..                    0 A (done)

The PRBS is :func:`telethermo.ident.prbs.prbs`: variable amplitude drawn from ``amplitude_A``, each bit
held ``hold_samples`` samples.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from telethermo.ident.prbs import prbs

#: largest experiment a plan may describe, samples (10^6 samples = 2.8 h at 10 ms)
MAX_SAMPLES = 1_000_000


@dataclass(frozen=True)
class IdentifyPlan:
    """An identification experiment, sample by sample.

    Attributes:
        seed: PRBS seed (training ``seed``, held-out ``seed + 1``), 0..65535.
        rest_samples: samples at 0 A first (reference temperature).
        train_samples: training PRBS length, samples (guiatni: 10,000 at 10 ms).
        validation_samples: held-out PRBS length, samples.
        amplitude_A: (a_min, a_max) range of the PRBS bit amplitudes, A.
        hold_samples: samples each PRBS bit is held.
        margin_C: the guard flips the current's sign within this distance of the envelope, °C.
    """

    seed: int = 0
    rest_samples: int = 200
    train_samples: int = 10_000
    validation_samples: int = 5_000
    amplitude_A: tuple[float, float] = (0.1, 1.0)
    hold_samples: int = 25
    margin_C: float = 1.0

    def __post_init__(self) -> None:
        def bad(name: str, expected: str) -> ValueError:
            return ValueError(f"IdentifyPlan.{name}: expected {expected}, got {getattr(self, name)!r}")

        for name, lo, hi in (
            ("seed", 0, 0xFFFF),
            ("rest_samples", 0, MAX_SAMPLES),
            ("train_samples", 1, MAX_SAMPLES),
            ("validation_samples", 1, MAX_SAMPLES),
            ("hold_samples", 1, 10_000),
        ):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not lo <= v <= hi:
                raise bad(name, f"an integer in {lo}..{hi}")
            object.__setattr__(self, name, int(v))
        try:
            a_lo, a_hi = (float(a) for a in self.amplitude_A)
        except (TypeError, ValueError):
            raise bad("amplitude_A", "(a_min, a_max), A") from None
        if not (math.isfinite(a_hi) and 0.0 <= a_lo <= a_hi):
            raise bad("amplitude_A", "(a_min, a_max) with 0 <= a_min <= a_max, A")
        object.__setattr__(self, "amplitude_A", (a_lo, a_hi))
        if not (isinstance(self.margin_C, (int, float)) and 0.0 <= self.margin_C <= 10.0):
            raise bad("margin_C", "a number in 0..10 °C")
        if self.total > MAX_SAMPLES:
            raise ValueError(f"IdentifyPlan: {self.total} samples in all; at most {MAX_SAMPLES}")

    @property
    def total(self) -> int:
        """Samples of the whole experiment (rest + training + held-out)."""
        return self.rest_samples + self.train_samples + self.validation_samples

    @property
    def fit_samples(self) -> int:
        """Samples the models are fitted on (rest + training)."""
        return self.rest_samples + self.train_samples

    def currents(self) -> np.ndarray:
        """The planned current of every sample, A (read-only array of :attr:`total` values)."""
        return _currents(self)

    def current_at(self, j: int) -> float:
        """The planned current of sample ``j``, A (0 outside the experiment)."""
        return float(_currents(self)[j]) if 0 <= j < self.total else 0.0

    def phase(self, j: int) -> str:
        """'rest', 'train', 'validation' or 'done' for sample ``j``."""
        if j < self.rest_samples:
            return "rest"
        if j < self.fit_samples:
            return "train"
        return "validation" if j < self.total else "done"

    def as_dict(self) -> dict[str, Any]:
        return {
            "seed": self.seed,
            "rest_samples": self.rest_samples,
            "train_samples": self.train_samples,
            "validation_samples": self.validation_samples,
            "amplitude_A": list(self.amplitude_A),
            "hold_samples": self.hold_samples,
            "margin_C": self.margin_C,
        }


@functools.lru_cache(maxsize=8)
def _currents(plan: IdentifyPlan) -> np.ndarray:
    u = np.concatenate(
        [
            np.zeros(plan.rest_samples),
            prbs(
                plan.train_samples,
                amplitude_A=plan.amplitude_A,
                hold_samples=plan.hold_samples,
                seed=plan.seed,
            ),
            prbs(
                plan.validation_samples,
                amplitude_A=plan.amplitude_A,
                hold_samples=plan.hold_samples,
                seed=plan.seed + 1,
            ),
        ]
    )
    u.setflags(write=False)
    return u


def guarded_current(
    u_A: float, T_sensor_C: float, *, I_limit_A: float, T_min_C: float, T_max_C: float, margin_C: float
) -> tuple[float, bool]:
    """The experiment's current for a planned ``u_A`` given the sensor temperature: clipped to
    ±``I_limit_A``; its sign flipped when the sensor is within ``margin_C`` of the envelope
    [T_min_C, T_max_C] and the current would push it further; 0 A for a non-finite temperature.

    Returns ``(current_A, guarded)``; ``guarded`` is True when the guard changed the current's sign or
    cut it (the clip alone is not counted).
    """
    i = min(max(float(u_A), -I_limit_A), I_limit_A)
    if not math.isfinite(T_sensor_C):
        return 0.0, True
    if (T_sensor_C > T_max_C - margin_C and i > 0.0) or (T_sensor_C < T_min_C + margin_C and i < 0.0):
        return -i, True
    return i, False
