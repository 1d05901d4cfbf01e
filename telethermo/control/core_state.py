"""The control core's state (:class:`CoreState`: everything :func:`telethermo.control.core.step`
remembers) and its life: :func:`init_state` from the first sample, :func:`replace_model` for a model loaded
into a running node, and :func:`predict`, the TEM model's prediction carried through the state.

The predictor is the only stateful object; its state is carried in :class:`CoreState` through
``snapshot()``/``restore()`` when the predictor offers them; a predictor without them makes a state
single-use (re-using an old state raises).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, cast

from telethermo.control import safety as sf
from telethermo.control.contact import ContactState
from telethermo.control.coreparams import CoreParams, Feedback, RenderPhase
from telethermo.control.estimators import Estimator, SnapshotPredictor, TemperaturePredictor, as_predictor
from telethermo.control.link_fallback import LinkState
from telethermo.control.material_stream import MaterialState, prepare
from telethermo.control.osc_guard import OscGuardState
from telethermo.control.passive_bound import PassiveBoundState
from telethermo.control.pi import PIState
from telethermo.control.types import Role
from telethermo.rig import RigSample

__all__ = ["CoreState", "init_state", "replace_model", "predict"]


class _PredictorCell:
    """Holds the predictor and which state-tick it is at (private to this module)."""

    __slots__ = ("predictor", "tick", "can_snapshot")

    def __init__(self, predictor: TemperaturePredictor) -> None:
        self.predictor = predictor
        self.tick = 0
        self.can_snapshot = callable(getattr(predictor, "snapshot", None)) and callable(
            getattr(predictor, "restore", None)
        )


@dataclass(frozen=True, slots=True)
class CoreState:
    """Everything ``step`` remembers. Treat as opaque; fields are for introspection and tests.

    Attributes:
        k: steps taken. t_s: time of the last sample, s. u_prev_A: the previous step's current command, A.
        env: safety envelope state. pi: PI integrator. contact: contact detector state.
        source: key of the setpoint source of the previous step (mode, phase) for bumpless switching.
        render_phase: :class:`RenderPhase` (RENDER mode).
        T_pred_C: the last model prediction, °C (NaN without a model).
        ident_k: IDENTIFY: steps since the experiment started (0 outside IDENTIFY); the plan is done once
            it reaches ``identify.total`` (the count goes on while 0 A is held);
        ident_guard: IDENTIFY: samples whose current the plan's guard flipped or cut.
        finger_seen: something has touched the pad since the start (its detector or the rig's flag): once
            the finger is lifted, air rendering holds neutral instead (before any finger it renders air,
            and both pads rest at ambient).
        render_later: RENDER in contact: (the render's ``LaterPhase``, its model state); restarted at each
            touch and whenever the rendered object changes. TELEPRESENCE on a slave with a virtual finger, in
            contact: (its ``VirtualFinger``, the skin's cells), restarted at each touch.
        material: (slave) the material identification's collector and last result.
        link: (master, telepresence) the graceful link loss's memory
            (:mod:`telethermo.control.link_fallback`).
        osc: (slave) the oscillation guard's memory and kp scale (:mod:`telethermo.control.osc_guard`).
        passive: (master, telepresence) the touch's passive bound (:mod:`telethermo.control.passive_bound`).
    """

    k: int
    t_s: float
    env: sf.EnvelopeState
    pi: PIState
    contact: ContactState
    u_prev_A: float
    source: tuple[Any, ...]
    render_phase: RenderPhase
    T_pred_C: float
    ident_k: int = 0
    ident_guard: int = 0
    finger_seen: bool = False
    pred_tick: int = 0
    pred_snapshot: Any = None
    render_later: Any = None
    cell: _PredictorCell | None = field(default=None, compare=False, repr=False)
    material: MaterialState = field(default_factory=MaterialState)
    link: LinkState = field(default_factory=LinkState)
    osc: OscGuardState = field(default_factory=OscGuardState)
    passive: PassiveBoundState = field(default_factory=PassiveBoundState)


def init_state(params: CoreParams, predictor_or_model: Any, first_sample: RigSample) -> CoreState:
    """Initial state from the first sample (the pad assumed at rest at ``first_sample.T_sensor_C``).

    ``predictor_or_model``: a :class:`TemperaturePredictor`, a model (``telethermo.ident.TemModel``)
    or None (only with the FLUX estimator and ESTIMATE feedback).
    """
    if predictor_or_model is None and (
        params.estimator is not Estimator.FLUX or params.feedback is Feedback.MODEL
    ):
        raise ValueError(
            f"init_state: estimator {params.estimator.value!r} / feedback {params.feedback.value!r} "
            "needs a TEM model (predictor_or_model is None)"
        )
    T0 = first_sample.T_sensor_C if math.isfinite(first_sample.T_sensor_C) else params.safety.neutral_C
    pred = as_predictor(predictor_or_model, T0)
    cell = _PredictorCell(pred) if pred is not None else None
    snap = cast(SnapshotPredictor, pred).snapshot() if cell is not None and cell.can_snapshot else None
    # bumpless from the current the rig is already driving (a display that was holding its pad)
    I0 = first_sample.current_A if math.isfinite(first_sample.current_A) else 0.0
    I0 = min(max(I0, -params.safety.I_cool_limit_A), params.safety.I_limit_A)
    if params.role is Role.SLAVE and params.material_id is not None:
        prepare(params.material_id, params.period_s)  # the fit's constants, outside any touch's cycle
    return CoreState(
        k=0,
        t_s=first_sample.t_s,
        env=sf.EnvelopeState(),
        pi=PIState(0.0),
        contact=ContactState(),
        u_prev_A=I0,
        source=(),
        render_phase=RenderPhase.PRESET,
        T_pred_C=T0 if pred else math.nan,
        pred_tick=0,
        pred_snapshot=snap,
        cell=cell,
    )


def replace_model(state: CoreState, predictor_or_model: Any, T0_C: float) -> CoreState:
    """``state`` with a new TEM model (or none): its predictor starts at rest at ``T0_C`` (°C), as
    :func:`init_state` starts one. For a model loaded into a running node (the pad may not be at rest:
    T_pred then carries the pad's transient until it decays). None is only for parameters that need
    no model (FLUX estimator, ESTIMATE feedback): the caller checks."""
    pred = as_predictor(predictor_or_model, T0_C)
    cell = _PredictorCell(pred) if pred is not None else None
    snap = cast(SnapshotPredictor, pred).snapshot() if cell is not None and cell.can_snapshot else None
    return replace(
        state, cell=cell, pred_tick=0, pred_snapshot=snap, T_pred_C=T0_C if pred is not None else math.nan
    )


def predict(state: CoreState, current_A: float) -> tuple[float, int, Any]:
    """T_pred for this sample. ``current_A``: the current held since the previous sample (the sample's
    measured current). The first sample is the predictor's rest state (no step yet)."""
    cell = state.cell
    if cell is None:
        return math.nan, state.pred_tick, None
    if state.k == 0:
        return state.T_pred_C, state.pred_tick, state.pred_snapshot
    if cell.tick != state.pred_tick:
        if not cell.can_snapshot:
            raise RuntimeError(
                "control.core.step: this CoreState was already used and its predictor cannot be "
                "restored (give the predictor snapshot()/restore(), or use each state once)"
            )
        cast(SnapshotPredictor, cell.predictor).restore(state.pred_snapshot)
    T = float(cell.predictor.step(current_A if math.isfinite(current_A) else 0.0))
    cell.tick = state.pred_tick + 1
    snap = cast(SnapshotPredictor, cell.predictor).snapshot() if cell.can_snapshot else None
    return T, cell.tick, snap
