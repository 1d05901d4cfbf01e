"""The one unit table (telethermo/units.py) knows every unit on the bus, and the naming rule agrees with the
parameter and object tables: each row's unit is the one its name's suffix implies (none when the name has
no unit suffix), and a parameter's field in the control core's parameters carries the same quantity on the
same scale (``R_sensor_C_per_W`` degC/W is CoreParams' ``R_sensor_K_per_W`` K/W)."""

from __future__ import annotations

import pytest

from telethermo.bus_config.objtable import OBJECTS
from telethermo.bus_config.partable import PARAMS
from telethermo.units import SUFFIXES, UNITS, same_quantity, unit_of_name


def test_every_suffix_names_a_unit_of_the_table():
    assert [u for _, u in SUFFIXES if u not in UNITS] == []
    # matched longest first: no suffix is shadowed by a shorter one listed before it
    for i, (suffix, _) in enumerate(SUFFIXES):
        assert not any(suffix.endswith(earlier) for earlier, _ in SUFFIXES[:i]), suffix


@pytest.mark.parametrize("p", PARAMS, ids=lambda p: p.name)
def test_a_parameters_unit_is_known_and_is_its_names(p):
    assert p.unit == "" or p.unit in UNITS, f"0x{p.index:04X} {p.name}: unit {p.unit!r} not in the table"
    assert unit_of_name(p.name) == p.unit, f"0x{p.index:04X} {p.name}: the suffix says otherwise"
    for var in (p.var(role) for role in ("master", "slave")):
        assert var.unit == p.unit  # the EDS Unit= key


@pytest.mark.parametrize("p", PARAMS, ids=lambda p: p.name)
def test_a_parameters_field_carries_the_same_quantity(p):
    for path in p.field:
        field_unit = unit_of_name(path.rsplit(".", 1)[-1])
        if field_unit and p.unit:
            assert same_quantity(p.unit, field_unit), f"{p.name} ({p.unit}) -> {path} ({field_unit})"


@pytest.mark.parametrize("row", OBJECTS, ids=lambda r: r.name)
def test_an_objects_unit_is_known_and_is_its_names(row):
    assert row.unit == "" or row.unit in UNITS, f"0x{row.index:04X} {row.name}: unit {row.unit!r}"
    assert unit_of_name(row.name) == row.unit, f"0x{row.index:04X} {row.name}: the suffix says otherwise"
