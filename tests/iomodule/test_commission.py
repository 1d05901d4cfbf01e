"""Commissioning a module process by SDO (telethermo.iomodule.commission, issue 24 item 1): the PDO mapping,
sampling period, heartbeat watch and safe substitute are written and read back; a refused value names the
object and the abort code; the commissioned module then sends the mapped inputs on SYNC."""

from __future__ import annotations

import dataclasses

import pytest

from telethermo.cia301 import ABORT_TOO_LOW
from telethermo.iomodule.commission import CommissionError, ModuleSetup, commission
from tests.iomodule.helpers import CONTROLLER_ID, MODULE_ID

pytestmark = pytest.mark.slow  # starts processes


def test_commissioning_is_written_read_back_and_takes_effect(rig):
    _, bus, _ = rig
    node = bus.node
    setup = ModuleSetup(MODULE_ID, CONTROLLER_ID, tpdos=(((0x6401, 2), (0x6401, 1)), ((0x2101, 0),)))
    back = dict(((i, s), v) for i, s, v in commission(node, setup))
    assert back[(0x2100, 0)] == 10 and back[(0x6443, 1)] == 1 and back[(0x6444, 1)] == 0
    assert back[(0x1016, 1)] == (CONTROLLER_ID << 16) | 150
    assert back[(0x1A00, 0)] == 2 and back[(0x1A00, 1)] == 0x64010210  # flux first, then the thermocouple
    # an independent read of the new mapping by canopen's PDO client, and the frames it then decodes
    node.tpdo.read(from_od=False)
    assert [v.od.subindex for v in node.tpdo[1].map] == [2, 1]
    frames = []
    node.tpdo[1].add_callback(lambda pdo: frames.append([v.raw for v in pdo]))
    node.nmt.send_command(0x01)
    bus.wait(lambda: bus.module_state() == 0x05)
    for k in range(3):
        bus.network.sync.transmit(k + 1)
        bus.wait(lambda: len(frames) > k)
    temp = node.sdo[0x6401][1].raw
    # 25 °C at 100 mV/°C, converted every SYNC (10 ms sampling)
    assert frames[-1][1] == temp and abs(temp - 8192) <= 50


def test_a_refused_value_names_the_object_and_the_abort_code(rig):
    _, bus, _ = rig
    with pytest.raises(CommissionError) as exc:
        commission(bus.node, dataclasses.replace(ModuleSetup(MODULE_ID, CONTROLLER_ID), sampling_ms=0))
    assert exc.value.code == ABORT_TOO_LOW and (exc.value.index, exc.value.subindex) == (0x2100, 0)
    assert str(exc.value) == (
        "io module 3: 0x2100:0 (adc_sampling_period_ms) = 0 refused: abort 0x06090032 "
        "(Value of parameter written too low (download only))"
    )
    assert bus.node.sdo[0x2100].raw == 400  # refused: the module kept its value
