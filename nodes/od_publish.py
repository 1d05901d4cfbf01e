"""The one typed map from a control cycle's results to the object dictionary: which object carries which
field of the rig's sample (:class:`telethermo.rig.RigSample`), of the core's step result
(:class:`telethermo.control.core.StepResult`) and of the slave's material answer
(:class:`telethermo.control.material_stream.MaterialEstimate`), with the object's index, CiA data type
and unit (checked against the shipped EDS files by tests/nodes/test_od_publish.py).

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

from telethermo.bus_config.od_types import BOOLEAN, REAL32, UNSIGNED8, UNSIGNED16, UNSIGNED32
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
    """One object the node writes: its index/sub-index, name, CiA data type and unit, and (for a published
    result) the field it carries: ``source`` (SAMPLE, RESULT or MATERIAL_ANSWER) and ``path`` (dotted
    attribute path in it), ``encode`` (field value -> object value) and ``finite_or_zero`` (a path of the
    same source: the object reads 0 while that field is not finite, i.e. no estimate)."""

    index: int
    name: str
    data_type: int
    unit: str = ""
    source: str = ""
    path: str = ""
    encode: Callable[[Any], Any] = _identity
    finite_or_zero: str = ""
    subindex: int = 0
    _get: Callable[[Any], Any] = field(init=False, repr=False, compare=False)
    _guard: Callable[[Any], Any] | None = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
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


def _S(index: int, name: str, data_type: int, unit: str, path: str, encode=_identity) -> OdRow:
    return OdRow(index, name, data_type, unit, SAMPLE, path, encode)


def _R(index: int, name: str, data_type: int, unit: str, path: str, encode=_identity) -> OdRow:
    return OdRow(index, name, data_type, unit, RESULT, path, encode)


def _M(index: int, name: str, data_type: int, path: str, encode=_identity, *, guarded=False) -> OdRow:
    unit = "degC" if name.endswith("_C") else ""
    return OdRow(index, name, data_type, unit, MATERIAL_ANSWER, path, encode, "effusivity" if guarded else "")


#: written every cycle, from the sample and the step result
CYCLE: tuple[OdRow, ...] = (
    _S(0x2000, "T_sensor_C", REAL32, "degC", "T_sensor_C"),
    _R(0x2001, "Q_W", REAL32, "W", "out.flux_W"),
    _R(0x2002, "current_A", REAL32, "A", "current_A"),
    _S(0x2003, "T_sink_C", REAL32, "degC", "T_sink_C"),
    _S(0x2004, "contact", BOOLEAN, "", "contact", _bool),
    _S(0x2005, "force_N", REAL32, "N", "force_N"),
    _R(0x2006, "contact_decision", BOOLEAN, "", "out.contact", _bool),
    _R(0x2100, "estimate_C", REAL32, "degC", "out.estimate_C"),
    _R(0x2101, "T_pred_C", REAL32, "degC", "status.T_pred_C"),
    _R(0x2102, "T_cmd_C", REAL32, "degC", "status.setpoint_C"),
    _R(0x2619, "link_fallback_active", BOOLEAN, "", "status.link_fallback", _bool),
    _R(0x2700, "safety_state", UNSIGNED8, "", "status.safety.state", _int),
    _R(0x2706, "active_trips", UNSIGNED16, "", "state.env.trips", sf.trips_mask),
    _R(0x2708, "limits_active", UNSIGNED8, "", "status.safety.limits_active", sf.limits_mask),
)

#: the slave's material answer (status.material), written when a touch has a new answer
MATERIAL: tuple[OdRow, ...] = (
    _M(0x2610, "identified_material", UNSIGNED8, "code"),
    _M(0x2611, "identified_beta", REAL32, "beta", guarded=True),
    _M(0x2612, "identified_se_ln_b", REAL32, "se_ln_b", guarded=True),
    _M(0x2613, "identified_posterior", REAL32, "posterior"),
    _M(0x2614, "identified_touches", UNSIGNED16, "touch", _u16),
    _M(0x261A, "identified_T_object0_C", REAL32, "T_object0_C", guarded=True),
    _M(0x261C, "identified_early_material", UNSIGNED8, "early_code"),
    _M(0x261D, "identified_early_posterior", REAL32, "early_posterior"),
    _M(0x261E, "identified_stage", UNSIGNED8, "stage", _stage),
)

#: what the cycle writes besides results: counters, the last trip's EMCY code, the fault-reset command
CYCLE_COUNTER = OdRow(0x2702, "cycle_counter", UNSIGNED32)
LATE_CYCLES = OdRow(0x2703, "late_cycles", UNSIGNED32)
LAST_TRIP_CODE = OdRow(0x2701, "last_trip_code", UNSIGNED16)
FAULT_RESET = OdRow(0x240A, "fault_reset", UNSIGNED8)
FAULT_RESET_BLOCKED_BY = OdRow(0x2707, "fault_reset_blocked_by", UNSIGNED16)
NODE_OBJECTS = (CYCLE_COUNTER, LATE_CYCLES, LAST_TRIP_CODE, FAULT_RESET, FAULT_RESET_BLOCKED_BY)

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
