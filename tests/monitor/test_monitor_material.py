"""The monitor names the slave's identified material (issue 15: "show it in status and the monitor"): the
slave's TPDO5 carries the contact flag, the material code (0x2610, the rendering table's 1-based position),
the touch counter and β; the monitor decodes it by the slave's EDS mapping and adds the material's name."""
from __future__ import annotations

import struct

import can

from telethermo.control.render_table import load_render_table
from telethermo.monitor.state import Monitor

from .conftest import monitor_config


def _tpdo5(code: int, touches: int, beta: float) -> can.Message:
    # slave 0x1A04: 0x2006 contact (8 bits), 0x2610 identified_material (8), 0x2614 touches (16), 0x2611 beta (32)
    return can.Message(timestamp=1.0, arbitration_id=0x682, data=struct.pack("<BBHf", 1, code, touches, beta),
                       is_extended_id=False)


def test_the_identified_material_is_shown_by_name_in_text_and_json():
    names = list(load_render_table())
    code = names.index("glass") + 1
    mon = Monitor(monitor_config())
    frame, _ = mon.feed(_tpdo5(code, 7, 1.47))
    assert f"identified_material={code} (glass)" in frame.text, frame.text
    values = {v["name"]: v for v in frame.fields["values"]}
    assert values["identified_material"]["value"] == code and values["identified_material"]["meaning"] == "glass"
    assert values["identified_touches"]["value"] == 7 and "meaning" not in values["identified_touches"]
    assert abs(values["identified_beta"]["value"] - 1.47) < 1e-6


def test_no_estimate_and_a_code_past_the_table_read_none():
    mon = Monitor(monitor_config())
    assert "identified_material=0 (none)" in mon.feed(_tpdo5(0, 0, 0.0))[0].text
    assert "identified_material=250 (none)" in mon.feed(_tpdo5(250, 1, 0.0))[0].text
