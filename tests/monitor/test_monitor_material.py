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
    # slave 0x1A04: 0x2006 contact (8 bits), 0x2610 identified_material (8), 0x2614 touches (16), 0x2611 beta
    # (32)
    return can.Message(
        timestamp=1.0,
        arbitration_id=0x682,
        data=struct.pack("<BBHf", 1, code, touches, beta),
        is_extended_id=False,
    )


def test_the_identified_material_is_shown_by_name_in_text_and_json():
    names = list(load_render_table())
    code = names.index("glass") + 1
    mon = Monitor(monitor_config())
    frame, _ = mon.feed(_tpdo5(code, 7, 1.47))
    assert f"identified_material={code} (glass)" in frame.text, frame.text
    values = {v["name"]: v for v in frame.fields["values"]}
    assert (
        values["identified_material"]["value"] == code and values["identified_material"]["meaning"] == "glass"
    )
    assert values["identified_touches"]["value"] == 7 and "meaning" not in values["identified_touches"]
    assert abs(values["identified_beta"]["value"] - 1.47) < 1e-6


def test_no_estimate_and_a_code_past_the_table_read_none():
    mon = Monitor(monitor_config())
    assert "identified_material=0 (none)" in mon.feed(_tpdo5(0, 0, 0.0))[0].text
    assert "identified_material=250 (none)" in mon.feed(_tpdo5(250, 1, 0.0))[0].text


def _sdo_upload(node: int, index: int, value: bytes, t: float) -> list[can.Message]:
    """An expedited SDO upload of ``index``:0 as a client and the node exchange it (raw CiA 301 frames)."""
    req = bytes([0x40, index & 0xFF, index >> 8, 0, 0, 0, 0, 0])
    resp = bytes([0x43, index & 0xFF, index >> 8, 0]) + value
    return [
        can.Message(timestamp=t, arbitration_id=0x600 + node, data=req, is_extended_id=False),
        can.Message(timestamp=t + 0.001, arbitration_id=0x580 + node, data=resp, is_extended_id=False),
    ]


def test_the_view_shows_the_material_with_the_posterior_read_for_this_touch():
    """Issue 25: the identified material with its posterior. identified_posterior (0x2613) is in no PDO of the
    shipped EDS: shown when an SDO read brings it, for the touch it was read in; said to be missing
    otherwise."""
    from telethermo.monitor.view import ViewState, render_lines

    names = list(load_render_table())
    code = names.index("glass") + 1
    mon = Monitor(monitor_config())
    mon.feed(_tpdo5(code, 7, 1.47))
    line = [ln for ln in render_lines(mon, ViewState(), 200, 40) if "identified glass" in ln]
    assert line == [
        f"  slave identified glass (code {code}, touch 7), posterior not on the bus "
        "(identified_posterior is in no PDO: telethermo get NODE identified_posterior)"
    ]
    for m in _sdo_upload(2, 0x2613, struct.pack("<f", 0.875), 1.1):
        mon.feed(m)
    assert mon.snapshot()["materials"] == [
        {
            "node": 2,
            "code": code,
            "material": "glass",
            "touches": 7,
            "posterior": 0.875,
            "posterior_source": "SDO",
            "stage": None,
            "early_code": None,
            "early_material": None,
            "early_posterior": None,
            "early_posterior_source": None,
        }
    ]
    assert f"slave identified glass (code {code}, touch 7), posterior 0.875 (SDO)" in "\n".join(
        render_lines(mon, ViewState(), 200, 40)
    )
    mon.feed(_tpdo5(code, 8, 1.47))  # the next touch: the posterior read for touch 7 is not shown for it
    assert mon.snapshot()["materials"][0]["posterior"] is None


def test_an_abstention_reads_unknown():
    mon = Monitor(monitor_config())
    frame, _ = mon.feed(_tpdo5(0xFF, 9, 0.0))
    assert "identified_material=255 (unknown)" in frame.text
    assert mon.snapshot()["materials"][0]["material"] == "unknown (abstained)"


def _tpdo6(T_object0_C: float, early: int, stage: int) -> can.Message:
    # slave 0x1A05: 0x261A identified_T_object0_C (32 bits), 0x261C identified_early_material (8),
    # 0x261E identified_stage (8)
    data = struct.pack("<fBB", T_object0_C, early, stage)
    return can.Message(timestamp=2.0, arbitration_id=0x6C2, data=data, is_extended_id=False)


def test_the_first_answer_and_the_refined_one_are_both_shown_for_their_touch():
    """Issue 23: the answer improves while the touch lasts. The slave's TPDO6 carries the touch's first answer
    (0x261C) and which answer identified_material holds (0x261E); the first answer's posterior (0x261D) comes
    by SDO. The monitor decodes them by the slave's EDS and shows both answers, each for its touch only."""
    from telethermo.monitor.view import ViewState, render_lines

    names = list(load_render_table())
    glass, brass = names.index("glass") + 1, names.index("brass") + 1
    mon = Monitor(monitor_config())
    mon.feed(_tpdo5(brass, 3, 60.0))
    frame, _ = mon.feed(_tpdo6(22.5, brass, 1))
    assert f"identified_early_material={brass} (brass)" in frame.text and "identified_stage=1" in frame.text
    j = mon.snapshot()["materials"][0]
    assert (j["stage"], j["early_material"], j["early_posterior"]) == ("first answer", "brass", None), j
    mon.feed(_tpdo5(glass, 3, 1.47))  # the same touch, refined: another material
    mon.feed(_tpdo6(22.5, brass, 2))
    for m in _sdo_upload(2, 0x261D, struct.pack("<f", 0.5), 2.1):
        mon.feed(m)
    j = mon.snapshot()["materials"][0]
    got = (j["material"], j["stage"], j["early_material"], j["early_posterior"], j["early_posterior_source"])
    assert got == ("glass", "refined", "brass", 0.5, "SDO"), j
    line = [ln for ln in render_lines(mon, ViewState(), 240, 40) if "identified glass" in ln]
    assert len(line) == 1 and f"glass (code {glass}, touch 3, refined)" in line[0], line
    assert line[0].endswith(f"; first answer brass (code {brass}), posterior 0.500 (SDO)"), line
    mon.feed(_tpdo5(glass, 4, 1.47))  # the next touch: the last touch's answers are not its own
    j = mon.snapshot()["materials"][0]
    assert (j["stage"], j["early_code"], j["early_posterior"]) == (None, None, None), j
