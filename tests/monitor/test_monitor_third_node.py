"""A third node the network file does not know, decoded by its own EDS (``monitor --eds NODE=FILE``):
its heartbeat, its TPDO by the EDS mapping and its SDO objects by name; bad ``--eds`` values are one
line and exit 2."""

from __future__ import annotations

import json
import struct

import can
import pytest

from telethermo.cli.main import EXIT_OK, EXIT_USAGE, main

from .conftest import SLAVE_EDS


@pytest.fixture
def arm_eds(tmp_path):
    eds = tmp_path / "arm.eds"
    eds.write_text(SLAVE_EDS.read_text().replace("telethermo slave", "test arm"))
    return eds


def _log(path):
    w = can.Logger(str(path))
    frames = [
        (0.0, 0x705, [0x05]),
        (0.01, 0x185, struct.pack("<ff", 41.5, 2.25)),
        (0.02, 0x605, struct.pack("<BHB4x", 0x40, 0x1017, 0)),
        (0.021, 0x585, struct.pack("<BHBL", 0x4B, 0x1017, 0, 100)),
    ]
    for t, cob, data in frames:
        w.on_message_received(
            can.Message(timestamp=1.7e9 + t, arbitration_id=cob, data=bytes(data), is_extended_id=False)
        )
    w.stop()


def test_a_third_node_is_decoded_by_its_own_eds(tmp_path, arm_eds, capsys):
    log = tmp_path / "t.log"
    _log(log)
    code = main(["monitor", "--replay", str(log), "--eds", f"5={arm_eds}", "--json"])
    out = capsys.readouterr().out.strip().splitlines()
    assert code == EXIT_OK
    frames = [json.loads(ln) for ln in out if '"type":"frame"' in ln]
    assert frames[1]["text"] == "TPDO1 node 5: estimate_C=41.500 degC, Q_W=2.250 W"
    assert "read 0x1017:00 Producer heartbeat time = 0x64" in frames[3]["text"]
    status = json.loads(out[-1])
    arm = next(n for n in status["nodes"] if n["node"] == 5)
    assert arm["name"] == "arm" and arm["nmt_state"] == "OPERATIONAL" and arm["sdo_ok"] == 1


@pytest.mark.parametrize(
    "spec, message",
    [
        ("5", "--eds '5': expected NODE=FILE with NODE a node-ID 1..127, e.g. 5=arm.eds"),
        ("200={eds}", "--eds '200={eds}': expected NODE=FILE with NODE a node-ID 1..127"),
        ("5={missing}", "--eds 5={missing}: {missing}: no such EDS file"),
        ("2={eds}", "--eds 2={eds}: node 2 is the network file's slave, whose EDS is"),
    ],
)
def test_bad_eds_option_is_one_line(tmp_path, arm_eds, capsys, spec, message):
    log = tmp_path / "t.log"
    _log(log)
    missing = tmp_path / "nope.eds"
    spec, message = spec.format(eds=arm_eds, missing=missing), message.format(eds=arm_eds, missing=missing)
    code = main(["monitor", "--replay", str(log), "--eds", spec, "--json"])
    err = capsys.readouterr().err
    assert code == EXIT_USAGE and message in err and len(err.strip().splitlines()) == 1
