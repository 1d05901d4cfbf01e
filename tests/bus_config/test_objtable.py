"""The manufacturer objects of both EDS files come entirely from the two tables: the operator parameters
(bus_config/partable.py, tests/bus_config/test_partable.py) and every other object (bus_config/objtable.py:
measurements, estimates, received peer values, model, commands, status, diagnostics). Checked with
canopen's own EDS parser (and EdsInfo for the REAL limits canopen drops)."""

from __future__ import annotations

import canopen
import pytest

from telethermo.bus_config import edsgen, objtable, path
from telethermo.bus_config.objtable import DOCS, KINDS, OBJECTS
from telethermo.bus_config.od_types import REAL32, REAL64, VISIBLE_STRING
from telethermo.bus_config.partable import PARAMS
from telethermo.device.eds_info import EdsInfo

ROLES = ("master", "slave")


def _od(role: str) -> canopen.ObjectDictionary:
    return canopen.import_od(str(path(f"{role}.eds")), edsgen.NODE_IDS[role])


@pytest.mark.parametrize("role", ROLES)
def test_every_manufacturer_object_of_the_eds_is_one_row_of_the_tables(role):
    in_eds = sorted(i for i in _od(role) if i >= 0x2000)
    rows = sorted([p.index for p in PARAMS] + [o.index for o in OBJECTS])
    assert in_eds == rows


def _expected_default(row: objtable.ObjRow):
    if row.data_type in (REAL32, REAL64):
        return float(row.default)
    if row.data_type == VISIBLE_STRING:
        return row.default
    return int(row.default)


@pytest.mark.parametrize("role", ROLES)
def test_every_row_is_in_the_eds_as_declared(role):
    od, info = _od(role), EdsInfo(path(f"{role}.eds"))
    for row in OBJECTS:
        obj = od[row.index]
        if row.subs:
            assert isinstance(obj, canopen.objectdictionary.ODArray), row.name
            assert obj.name == row.name and obj[0].default == row.subs == len(obj) - 1, row.name
            entries = [(obj[i], f"{row.sub_name}{i}") for i in range(1, row.subs + 1)]
        else:
            assert isinstance(obj, canopen.objectdictionary.ODVariable), row.name
            entries = [(obj, row.name)]
        for var, name in entries:
            got = (var.name, var.data_type, var.access_type, var.pdo_mappable, var.unit, var.description)
            assert got == (name, row.data_type, row.access, row.pdo, row.unit, row.doc), name
            assert var.default == _expected_default(row), name
            vi = info.vars[(row.index, var.subindex)]
            assert (vi.low, vi.high) == (row.low, row.high), name


def test_the_rows_are_in_order_named_once_documented_and_kinded():
    assert [o.index for o in OBJECTS] == sorted({o.index for o in OBJECTS})
    names = [o.name for o in OBJECTS] + [p.name for p in PARAMS]
    assert len(set(names)) == len(names)
    assert set(DOCS) == {o.name for o in OBJECTS} and all(DOCS.values())
    assert {o.kind for o in OBJECTS} <= set(KINDS)
    # the bus only writes what is meant to be written: received values (rww, by RPDO), model, commands
    for o in OBJECTS:
        writable = o.access != "ro"
        assert writable is (o.kind in ("received", "model", "command")), o.name
        assert (o.low is not None) is writable, o.name  # every writable object has a range
