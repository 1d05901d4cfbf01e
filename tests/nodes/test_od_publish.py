"""The typed map from a cycle's results to the object dictionary (nodes/od_publish.py): every row names an
object of the object table and of the shipped EDS files as canopen's own parser reads them (index, name,
type, unit, access), the values a real step gives have the Python type of their CiA type, every
field of the step result is published exactly once or declared unpublished, and the values a real step
produces reach the objects as a canopen SDO client reads them."""

from __future__ import annotations

import dataclasses
import math
import uuid

import canopen
import pytest

from telethermo.bus_config import edsgen, path
from telethermo.bus_config.objtable import ESTIMATE, MEASURED, STATUS
from telethermo.bus_config.od_types import BOOLEAN, REAL32, UNSIGNED8, UNSIGNED16, UNSIGNED32
from telethermo.control import safety as sf
from telethermo.control.core import StepResult, StepStatus, init_state, step
from telethermo.control.material_stream import MaterialEstimate
from telethermo.control.params import default_params
from telethermo.control.types import Outgoing, PeerValues, Role
from telethermo.device import Device
from telethermo.nodes import ident_service as ident
from telethermo.nodes import od_publish as op
from telethermo.rig import RigSample

ROWS = (*op.CYCLE, *op.MATERIAL, *op.NODE_OBJECTS, *ident.WRITTEN, ident.FETCH_SAMPLE)
#: the commands among them: written by SDO too (each reads 0 again, or selects what the node writes)
COMMANDS = (op.FAULT_RESET, ident.FETCH_SAMPLE)


@pytest.mark.parametrize("role", ("master", "slave"))
def test_every_row_is_an_object_of_the_eds_with_its_type_and_unit(role):
    od = canopen.import_od(str(path(f"{role}.eds")), edsgen.NODE_IDS[role])
    for row in ROWS:
        var = od[row.index] if row.subindex == 0 else od[row.index][row.subindex]
        assert isinstance(var, canopen.objectdictionary.ODVariable), row.name
        assert (var.name, var.data_type, var.unit) == (row.name, row.data_type, row.unit), row.name
        # the node writes them; on the bus they are read-only, except the commands
        assert var.access_type == ("rw" if row in COMMANDS else "ro"), row.name


def test_each_object_is_written_by_one_row():
    assert len({r.key for r in ROWS}) == len({r.name for r in ROWS}) == len(ROWS)
    # what a cycle publishes is read-only on the bus: a measurement, an estimate or the node's status
    assert {r.kind for r in (*op.CYCLE, *op.MATERIAL, *ident.WRITTEN)} <= {MEASURED, ESTIMATE, STATUS}


def test_the_identification_record_keeps_what_the_tpdos_carry_in_the_fetched_objects_order():
    """Each column of the experiment's record is a field a cycle row publishes (its TPDOs carry that object),
    written back by a fetch into the object of the same unit and type (REAL32)."""
    cycle = {(r.source, r.path): r for r in op.CYCLE}
    assert [r.name for r in ident.RECORD] == [
        "ident_fetched_T_sensor_C", "ident_fetched_current_A", "ident_fetched_Q_W",
    ]  # fmt: skip
    for row in ident.RECORD:
        published = cycle[row.source, row.path]
        assert (row.data_type, row.unit) == (published.data_type, published.unit) and row.data_type == REAL32
        assert row.name == "ident_fetched_" + published.name


def test_a_row_names_an_object_of_the_table():
    with pytest.raises(ValueError, match=r"bus_config/objtable.py: no VAR object 'T_skin_C'"):
        op.OdRow("T_skin_C", op.SAMPLE, "T_sensor_C")
    with pytest.raises(ValueError, match="no VAR object 'theta'"):  # an ARRAY is not one value
        op.OdRow("theta", op.RESULT, "current_A")


#: the Python type of a value each CiA type takes (canopen's encode_raw packs it as such)
PY_TYPES = {BOOLEAN: bool, UNSIGNED8: int, UNSIGNED16: int, UNSIGNED32: int, REAL32: float}


def _leaves(cls, prefix: str, expand: dict) -> list[str]:
    out = []
    for f in dataclasses.fields(cls):
        name = prefix + f.name
        out.extend(_leaves(expand[name], name + ".", expand) if name in expand else [name])
    return out


def test_every_field_of_the_step_result_is_published_once_or_declared_unpublished():
    expand = {"out": Outgoing, "status": StepStatus, "status.safety": sf.EnvelopeStatus}
    result_fields = _leaves(StepResult, "", expand)
    material_fields = ["material." + p for p in _leaves(MaterialEstimate, "", {})]
    published = [r.path for r in op.CYCLE if r.source == op.RESULT]
    published += ["material." + r.path for r in op.MATERIAL]
    opaque = [p for p in op.NOT_PUBLISHED if p == "state"]  # the memory: only its trips are read
    for leaf in result_fields + material_fields:
        if leaf == "status.material":  # the answer itself: its fields are the MaterialEstimate leaves
            continue
        count = published.count(leaf)
        assert (count, leaf in op.NOT_PUBLISHED) in ((1, False), (0, True)), leaf
    known = set(result_fields) | set(material_fields) | {"material.beta"}  # beta: a property of the answer
    for p in published:
        assert p in known or any(p.startswith(o + ".") for o in opaque), p
    assert set(op.NOT_PUBLISHED) <= set(result_fields) | set(material_fields)
    samples = [r.path for r in op.CYCLE if r.source == op.SAMPLE]
    assert len(samples) == len(set(samples)) and set(samples) <= {
        f.name for f in dataclasses.fields(RigSample)
    }


def _tripped_slave_step() -> tuple[RigSample, StepResult]:
    """A real step of the slave's core with a hot heat sink: a trip, a limit, non-zero masks."""
    params = default_params(Role.SLAVE)
    first = RigSample(0.0, 30.0, 0.1, 0.0, False, 26.0)
    res = step(first, PeerValues(33.0, 0.0), params, init_state(params, None, first))
    sample = RigSample(0.01, 30.5, 0.2, 0.3, True, 70.0, 2.5)
    return sample, step(sample, PeerValues(34.0, 0.1), params, res.state)


def _answer() -> MaterialEstimate:
    return MaterialEstimate(
        effusivity=7000.0, se_ln_b=0.1, code=3, posterior=0.9, touch=0x1_0005, T_object0_C=24.0,
        early_code=2, early_posterior=0.6, stage="late",
    )  # fmt: skip


def test_the_values_of_a_real_step_have_the_python_type_of_their_cia_type():
    sample, res = _tripped_slave_step()
    for row in op.CYCLE:
        value = row.value(sample if row.source == op.SAMPLE else res)
        assert type(value) is PY_TYPES[row.data_type], (row.name, value)
    for row in op.MATERIAL:
        for answer in (_answer(), MaterialEstimate(touch=4, stage="early")):
            assert type(row.value(answer)) is PY_TYPES[row.data_type], row.name


def test_a_real_step_and_answer_reach_the_objects_as_canopen_reads_them():
    sample, res = _tripped_slave_step()
    assert res.state.env.trips and res.status.safety.limits_active  # the masks are not trivially zero
    answer = _answer()
    channel = f"tt-{uuid.uuid4().hex[:10]}"
    nets = [canopen.Network(), canopen.Network()]
    for net in nets:
        net.connect(interface="virtual", channel=channel)
    dev = Device(nets[0], 2, path("slave.eds"))
    try:
        dev.start()
        publisher = op.Publisher(dev.writer)
        with dev.lock:
            publisher.cycle(sample, res)
            publisher.material(answer)
        client = nets[1].add_node(2, str(path("slave.eds")))
        got = {r.name: client.sdo[r.index].raw for r in (*op.CYCLE, *op.MATERIAL)}
    finally:
        dev.close()
        for net in nets:
            net.disconnect()
    f32 = lambda x: pytest.approx(x, rel=1e-6)  # noqa: E731  REAL32 on the bus
    assert got["T_sensor_C"] == f32(30.5) and got["T_sink_C"] == f32(70.0) and got["force_N"] == f32(2.5)
    assert got["Q_W"] == f32(res.out.flux_W) and got["estimate_C"] == f32(res.out.estimate_C)
    assert got["current_A"] == f32(res.current_A) and got["T_cmd_C"] == f32(res.status.setpoint_C)
    assert got["contact"] is True and got["contact_decision"] is bool(res.out.contact)
    assert got["safety_state"] == int(res.status.safety.state)
    assert got["active_trips"] == sf.trips_mask(res.state.env.trips) != 0
    assert got["limits_active"] == sf.limits_mask(res.status.safety.limits_active) != 0
    assert got["identified_material"] == 3 and got["identified_touches"] == 5
    assert got["identified_beta"] == f32(answer.beta) and got["identified_stage"] == 2
    assert got["identified_early_material"] == 2 and got["identified_T_object0_C"] == f32(24.0)


def test_an_answer_without_an_estimate_reads_zero_where_the_old_writes_did():
    values = {r.name: r.value(MaterialEstimate(touch=4, stage="early")) for r in op.MATERIAL}
    assert values == {
        "identified_material": 0, "identified_beta": 0.0, "identified_se_ln_b": 0.0,
        "identified_posterior": 0.0, "identified_touches": 4, "identified_T_object0_C": 0.0,
        "identified_early_material": 0, "identified_early_posterior": 0.0, "identified_stage": 1,
    }  # fmt: skip
    assert math.isnan(MaterialEstimate().beta)
