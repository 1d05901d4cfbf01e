"""What one control step gives (:func:`telethermo.control.core.step`): :class:`StepResult` (the current,
the values to send, the next state) and :class:`StepStatus` (what happened, for the node's status/EMCY
objects and the recordings)."""

from __future__ import annotations

from dataclasses import dataclass

from telethermo.control import safety as sf
from telethermo.control.core_state import CoreState
from telethermo.control.coreparams import RenderPhase
from telethermo.control.material_stream import MaterialEstimate
from telethermo.control.pi import PIComponents
from telethermo.control.types import Outgoing

__all__ = ["StepStatus", "StepResult"]


@dataclass(frozen=True, slots=True)
class StepStatus:
    """What happened in one step (for the node's status/EMCY objects and the recordings).

    Attributes:
        safety: :class:`telethermo.control.safety.EnvelopeStatus` (state, trips, new_trips,
            error_register, limits_active; ``.emcy_codes`` / ``.new_emcy_codes``).
        requested_setpoint_C: what the mode asked for, °C (NaN if nothing, e.g. a bad peer).
        setpoint_C: after the envelope, °C.
        feedback_C: what the PI compared with the setpoint, °C.
        T_pred_C: model prediction, °C (NaN without a model).
        estimate_C: the estimate sent to the peer, °C; estimate_model_C, estimate_flux_C: both kinds.
        contact: contact detected from the signals.
        render_phase: RENDER phase (PRESET/CONTACT) or None.
        pi: :class:`telethermo.control.pi.PIComponents`.
        current_requested_A: the controller's output before the envelope's current limits, A.
        material: (slave) the last identified material (None on the master or with identification off).
        link_fallback: (master) the slave is lost and the master renders the last identified material itself;
            link_fallback_started: it started in this step (raise its EMCY once).
    """

    safety: sf.EnvelopeStatus
    requested_setpoint_C: float
    setpoint_C: float
    feedback_C: float
    T_pred_C: float
    estimate_C: float
    estimate_model_C: float
    estimate_flux_C: float
    contact: bool
    render_phase: RenderPhase | None
    pi: PIComponents
    current_requested_A: float
    material: MaterialEstimate | None = None
    link_fallback: bool = False
    link_fallback_started: bool = False

    # convenience for the node layer
    @property
    def safety_state(self) -> sf.SafetyState:
        return self.safety.state

    @property
    def trips(self) -> tuple[sf.Trip, ...]:
        return self.safety.trips

    @property
    def new_emcy_codes(self) -> tuple[int, ...]:
        return self.safety.new_emcy_codes

    @property
    def error_register(self) -> int:
        return self.safety.error_register


@dataclass(frozen=True, slots=True)
class StepResult:
    """Output of :func:`step`: apply ``current_A``, send ``out`` (TPDO1), keep ``state``."""

    current_A: float
    out: Outgoing
    state: CoreState
    status: StepStatus
