"""The one typed map from a control cycle's results to the object dictionary: which object carries which
field of the rig's sample (:class:`telethermo.rig.RigSample`), of the core's step result
(:class:`telethermo.control.core.StepResult`) and of the slave's material answer
(:class:`telethermo.control.material_stream.MaterialEstimate`). A row names its object; the object's
index, CiA data type, unit and kind come from its row in ``bus_config/objtable.py`` (the table the EDS
files are generated from; tests/nodes/test_od_publish.py checks them against the shipped EDS files too).

- :data:`CYCLE`: written every control cycle (TPDO1 carries estimate and flux at this very SYNC);
- :data:`MATERIAL`: written when the slave has a new answer (a new touch, or its refined answer);
- :data:`NODE_OBJECTS`: what the cycle writes that is not a step result (counters, trip code, commands);
- :data:`NOT_PUBLISHED`: the step result's fields that no object carries, and why.

A field of the step result is either published by exactly one row or listed in :data:`NOT_PUBLISHED`
(the test enumerates the dataclasses' fields, so a new field needs a decision).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from operator import attrgetter
from typing import Any, Callable

from telethermo.bus_config.objtable import BY_NAME
from telethermo.control import safety as sf

#: identified_stage (0x261E) of MaterialEstimate.stage
STAGE_CODES = {"": 0, "early": 1, "late": 2}

# where a row's value comes from
SAMPLE = "sample"  # the rig's sample of this cycle (RigSample)
RESULT = "result"  # the core's step result (StepResult)
MATERIAL_ANSWER = "material"  # the slave's last answer (MaterialEstimate)


def _identity(value: Any) -> Any:
    return value


@dataclass(frozen=True)
class OdRow:
    """One object the node writes, by name, and (for a published result) the field it carries: ``source``
    (SAMPLE, RESULT or MATERIAL_ANSWER) and ``path`` (dotted attribute path in it), ``encode`` (field value
    -> object value) and ``finite_or_zero`` (a path of the same source: the object reads 0 while that field
    is not finite, i.e. no estimate). ``index``, ``data_type`` (CiA), ``unit`` and ``kind`` are the
    object's, from bus_config/objtable.py."""

    name: str
    source: str = ""
    path: str = ""
    encode: Callable[[Any], Any] = _identity
    finite_or_zero: str = ""
    index: int = field(init=False)
    subindex: int = field(init=False, default=0)
    data_type: int = field(init=False)
    unit: str = field(init=False)
    kind: str = field(init=False)
    _get: Callable[[Any], Any] = field(init=False, repr=False, compare=False)
    _guard: Callable[[Any], Any] | None = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        obj = BY_NAME.get(self.name)
        if obj is None or obj.subs:
            raise ValueError(f"bus_config/objtable.py: no VAR object {self.name!r} (nodes/od_publish.py)")
        for name, value in (("index", obj.index), ("data_type", obj.data_type), ("unit", obj.unit)):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "kind", obj.kind)
        object.__setattr__(self, "_get", attrgetter(self.path) if self.path else _identity)
        object.__setattr__(self, "_guard", attrgetter(self.finite_or_zero) if self.finite_or_zero else None)

    @property
    def key(self) -> tuple[int, int]:
        """(index, sub-index): how the device names the object."""
        return self.index, self.subindex

    def value(self, root: Any) -> Any:
        """The object's value from ``root`` (the source object: a sample, a step result or an answer)."""
        if self._guard is not None and not math.isfinite(self._guard(root)):
            return self.encode(0.0)
        return self.encode(self._get(root))


def _bool(value: Any) -> bool:
    return bool(value)


def _int(value: Any) -> int:
    return int(value)


def _u16(value: int) -> int:
    return value & 0xFFFF


def _stage(stage: str) -> int:
    return STAGE_CODES[stage]


def _S(name: str, path: str, encode: Callable[[Any], Any] = _identity) -> OdRow:
    return OdRow(name, SAMPLE, path, encode)


def _R(name: str, path: str, encode: Callable[[Any], Any] = _identity) -> OdRow:
    return OdRow(name, RESULT, path, encode)


def _M(name: str, path: str, encode: Callable[[Any], Any] = _identity, *, guarded: bool = False) -> OdRow:
    return OdRow(name, MATERIAL_ANSWER, path, encode, "effusivity" if guarded else "")


#: written every cycle, from the sample and the step result
CYCLE: tuple[OdRow, ...] = (
    _S("T_sensor_C", "T_sensor_C"),
    _R("Q_W", "out.flux_W"),
    _R("current_A", "current_A"),
    _S("T_sink_C", "T_sink_C"),
    _S("contact", "contact", _bool),
    _S("force_N", "force_N"),
    _R("contact_decision", "out.contact", _bool),
    _R("estimate_C", "out.estimate_C"),
    _R("T_pred_C", "status.T_pred_C"),
    _R("T_cmd_C", "status.setpoint_C"),
    _R("link_fallback_active", "status.link_fallback", _bool),
    _R("safety_state", "status.safety.state", _int),
    _R("active_trips", "state.env.trips", sf.trips_mask),
    _R("limits_active", "status.safety.limits_active", sf.limits_mask),
)

#: the slave's material answer (status.material), written when a touch has a new answer
MATERIAL: tuple[OdRow, ...] = (
    _M("identified_material", "code"),
    _M("identified_beta", "beta", guarded=True),
    _M("identified_se_ln_b", "se_ln_b", guarded=True),
    _M("identified_posterior", "posterior"),
    _M("identified_touches", "touch", _u16),
    _M("identified_T_object0_C", "T_object0_C", guarded=True),
    _M("identified_early_material", "early_code"),
    _M("identified_early_posterior", "early_posterior"),
    _M("identified_stage", "stage", _stage),
)

#: what the cycle writes besides results: counters, the last trip's EMCY code, the fault-reset command
CYCLE_COUNTER = OdRow("cycle_counter")
LATE_CYCLES = OdRow("late_cycles")
INPUT_TIMEOUTS = OdRow("input_timeouts")
MODULE_RESTARTS = OdRow("module_restarts")
LAST_TRIP_CODE = OdRow("last_trip_code")
FAULT_RESET = OdRow("fault_reset")
FAULT_RESET_BLOCKED_BY = OdRow("fault_reset_blocked_by")
NODE_OBJECTS = (
    CYCLE_COUNTER,
    LATE_CYCLES,
    INPUT_TIMEOUTS,
    MODULE_RESTARTS,
    LAST_TRIP_CODE,
    FAULT_RESET,
    FAULT_RESET_BLOCKED_BY,
)

#: fields of the step result (paths as in the rows) that no object carries, and why
NOT_PUBLISHED: dict[str, str] = {
    "state": "the controller's memory between cycles (its latched trips: active_trips)",
    "out.material_code": "the slave's answer goes out as identified_material (MATERIAL rows)",
    "out.material_beta": "as identified_beta (MATERIAL rows)",
    "out.material_touch": "as identified_touches (MATERIAL rows)",
    "out.material_T_object0_C": "as identified_T_object0_C (MATERIAL rows)",
    "status.requested_setpoint_C": "recorded only (telethermo.offline.runner.side_row)",
    "status.feedback_C": "recorded only",
    "status.estimate_C": "the same value as out.estimate_C (estimate_C)",
    "status.estimate_model_C": "recorded only",
    "status.estimate_flux_C": "recorded only",
    "status.contact": "the same decision as out.contact (contact_decision)",
    "status.render_phase": "recorded only",
    "status.pi": "recorded only (the PI's components)",
    "status.current_requested_A": "recorded only",
    "status.link_fallback_started": "raises EMCY 0xFF01 (nodes.cycle), not an object",
    "status.safety.trips": "the latched set is published from state.env.trips (active_trips)",
    "status.safety.new_trips": "one EMCY each, and last_trip_code",
    "status.safety.error_register": "0x1001, kept by the device's EMCY producer",
    "material.effusivity": "published relative to skin, as identified_beta (its property beta)",
    "material.abstained": "logged only: why the answer is unknown",
    "material.by": "logged only: which identifier answered",
}


class Publisher:
    """The rows bound to a device's fast writers: ``cycle(sample, result)`` and ``material(answer)``."""

    def __init__(self, writer: Callable[[tuple[int, int]], Callable[[Any], None]]) -> None:
        self._cycle = [(row.source == SAMPLE, row.value, writer(row.key)) for row in CYCLE]
        self._material = [(row.value, writer(row.key)) for row in MATERIAL]

    def cycle(self, sample: Any, result: Any) -> None:
        """This cycle's sample and step result into their objects."""
        for from_sample, value, write in self._cycle:
            write(value(sample if from_sample else result))

    def material(self, answer: Any) -> None:
        """The slave's material answer into 0x2610..0x2614, 0x261A and 0x261C..0x261E."""
        for value, write in self._material:
            write(value(answer))
