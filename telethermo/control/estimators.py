"""Contact-temperature estimators: what the finger (master) or the object (slave) sees (guiatni §4).

The heat-flux sensor (thickness e, thermocouple at its mid-plane) sits between the TEM plate
(temperature T_1) and the contact (T_2). With a linear profile across the thin sensor (eq. 26-29):

- **model** estimator, the paper's (eq. 28/30/31): ``T_2 = 2·T_sensor - T_pred``, where T_pred is
  the TEM plate temperature predicted from the drive current by the identified NARMA model (eq. 32);
- **flux** estimator (eq. 29): ``T_2 = T_sensor - Q·R_sensor/2`` with R_sensor = e/(k·S) the
  sensor's thermal resistance, K/W, and Q > 0 out of the pad (rig sign convention);
- **fused**: ``w·model + (1 - w)·flux``.

The predictor is anything with ``step(current_A) -> T_pred_C`` and ``reset(T_C)``
(:class:`TemperaturePredictor`), e.g. ``telethermo.ident``'s streaming free-run predictor.
"""

from __future__ import annotations

from enum import Enum
from typing import Any, Protocol, cast, runtime_checkable


class Estimator(str, Enum):
    """Which contact-temperature estimate a controller uses and sends."""

    MODEL = "model"  # guiatni eq. 30/31: 2·T_sensor - T_pred
    FLUX = "flux"  # eq. 29: T_sensor - Q·R_sensor/2
    FUSED = "fused"  # w·model + (1 - w)·flux


@runtime_checkable
class TemperaturePredictor(Protocol):
    """A streaming free-run model of the TEM plate temperature from the drive current."""

    def step(self, current_A: float) -> float:
        """Advance one sample with ``current_A`` (A) applied; return the predicted T_pred, °C."""
        ...

    def reset(self, T_C: float) -> None:
        """Restart the free run from a steady state at ``T_C`` (°C)."""
        ...


class SnapshotPredictor(TemperaturePredictor, Protocol):
    """A :class:`TemperaturePredictor` whose state can be saved and put back (the control core then
    carries it in its state, so a state can be stepped more than once)."""

    def snapshot(self) -> Any:
        """The predictor's state, opaque to the caller."""
        ...

    def restore(self, snap: Any) -> None:
        """Put back a state ``snapshot()`` returned."""
        ...


def estimate_model(T_sensor_C: float, T_pred_C: float) -> float:
    """Contact-side temperature from the mid-plane sensor and the predicted plate, °C (eq. 28).

    >>> estimate_model(30.0, 31.0)      # plate at 31 °C, mid-plane at 30 °C: the contact side at 29 °C
    29.0
    """
    return 2.0 * T_sensor_C - T_pred_C


def estimate_flux(T_sensor_C: float, Q_W: float, R_sensor_K_per_W: float) -> float:
    """Contact-side temperature from the mid-plane sensor and the flux through it, °C (eq. 29).

    Q_W > 0 flows from the TEM towards the contact, so the contact side is colder by Q·R/2.

    >>> estimate_flux(30.0, 0.2, 5.0)   # 0.2 W through 5 K/W: the contact is 0.5 °C below the sensor
    29.5
    """
    return T_sensor_C - 0.5 * Q_W * R_sensor_K_per_W


def estimate(
    kind: Estimator,
    T_sensor_C: float,
    Q_W: float,
    T_pred_C: float,
    R_sensor_K_per_W: float,
    fused_weight: float = 0.5,
) -> float:
    """The estimate of ``kind``, °C. ``fused_weight`` is the weight of the model estimate.

    >>> estimate(Estimator.FUSED, 30.0, 0.2, 31.0, 5.0, fused_weight=0.5)   # halfway between 29.0 and 29.5
    29.25
    """
    if kind is Estimator.FLUX:
        return estimate_flux(T_sensor_C, Q_W, R_sensor_K_per_W)
    if kind is Estimator.MODEL:
        return estimate_model(T_sensor_C, T_pred_C)
    return fused_weight * estimate_model(T_sensor_C, T_pred_C) + (1.0 - fused_weight) * estimate_flux(
        T_sensor_C, Q_W, R_sensor_K_per_W
    )


def as_predictor(predictor_or_model: Any, T0_C: float) -> TemperaturePredictor | None:
    """A predictor from a predictor, a model with ``.temperature.predictor(T0_C=...)`` or None."""
    if predictor_or_model is None:
        return None
    if isinstance(predictor_or_model, TemperaturePredictor):
        predictor_or_model.reset(T0_C)
        return predictor_or_model
    temp = getattr(predictor_or_model, "temperature", None)
    if temp is not None and callable(getattr(temp, "predictor", None)):
        return cast(TemperaturePredictor, temp.predictor(T0_C=T0_C))
    if callable(getattr(predictor_or_model, "predictor", None)):
        return cast(TemperaturePredictor, predictor_or_model.predictor(T0_C=T0_C))
    raise TypeError(
        "init_state: expected a TemperaturePredictor (step/reset), a model with "
        f".temperature.predictor(T0_C=...), or None; got {type(predictor_or_model).__name__}"
    )
