"""bus_config/io_module.eds is the one bus_config/io_eds.py renders, and the objects it builds with the
nodes' builders (bus_config/od_communication.py) carry the I/O module's own values, read back by canopen's
own EDS parser."""

from __future__ import annotations

import canopen
import pytest

from telethermo.bus_config import io_eds, path


def test_the_io_module_eds_is_the_generated_one():
    """Regenerate: python -m telethermo.bus_config.io_eds."""
    assert io_eds.main(["--check"]) == 0


def test_the_check_sees_a_stale_io_module_eds_and_regenerates_it(tmp_path, monkeypatch, capsys):
    stale = tmp_path / io_eds.FILE_NAME
    stale.write_text(io_eds.render().replace("ProductNumber=0x00000401", "ProductNumber=0x00000402"))
    monkeypatch.setattr(io_eds, "_path", lambda name: tmp_path / name)
    assert io_eds.main(["--check"]) == 1
    assert str(stale) in capsys.readouterr().err
    assert io_eds.main([]) == 0 and io_eds.main(["--check"]) == 0
    assert stale.read_text(encoding="ascii") == path(io_eds.FILE_NAME).read_text(encoding="ascii")


@pytest.mark.parametrize(
    ("file_name", "node_id", "product_code", "sync_overflow", "device_type", "sync_cob_id"),
    [
        ("io_module.eds", 3, 0x0401, 0, io_eds.DEVICE_TYPE, 0x80),
        ("master.eds", 1, 1, 240, 0, 0x40000080),
        ("slave.eds", 2, 2, 240, 0, 0x80),
    ],
)
def test_the_shared_communication_objects_carry_each_devices_values(
    file_name, node_id, product_code, sync_overflow, device_type, sync_cob_id
):
    od = canopen.import_od(str(path(file_name)), node_id)
    assert od[0x1000].default == device_type
    assert od[0x1005].default == sync_cob_id
    assert od[0x1018][2].default == product_code
    assert od[0x1019].default == sync_overflow
    assert od[0x1014].default == 0x80 + node_id  # $NODEID resolved by canopen
    assert od[0x1016][0].default == 2 and od[0x1017].default == 100
    assert (0x1010 in od, 0x1029 in od) == ((False, True) if file_name == "io_module.eds" else (True, False))


def test_the_sampling_period_keeps_its_unit():
    od = canopen.import_od(str(path("io_module.eds")), 3)
    assert od[io_eds.SAMPLING_INDEX].unit == "ms"
