"""``telethermo apply-gains``: a tuned gains file into a running master process (the lone_master fixture),
by SDO, checked by canopen's own client from the shipped EDS; the gains without an object named in one line
for a restart with --gains; the file's "apply" marks are the EDS's truth; bad files and a node in another
mode refused with nothing written (issue 25)."""

from __future__ import annotations

import json

import canopen
import pytest

from telethermo.bus_config import path as eds_path
from telethermo.cli.main import EXIT_FAIL, EXIT_OK, EXIT_USAGE
from telethermo.control.defaults import GAINS
from telethermo.control.gainsfile import GAINS_FORMAT, RESTART_GAIN_FIELDS, SDO_GAIN_FIELDS, apply_marks
from telethermo.control.types import Role
from telethermo.device.eds_info import load as load_eds
from telethermo.nodes.launch import wait_for

TUNED = {
    "kp_A_per_C": 1.25,
    "ki_A_per_C_s": 0.0625,
    "kQ_A_per_W": 0.5,
    "kpQ_A_per_W": 0.5,
    "kiQ_A_per_W_s": 0.25,
}  # exact in REAL32, so the read-back compares equal


def gains_file(tmp_path, **extra):
    doc = {
        "format": GAINS_FORMAT,
        "period_s": 0.01,
        "master": dict(TUNED),
        "slave": {k: GAINS[Role.SLAVE][k] for k in TUNED},
        "apply": apply_marks(),
        **extra,
    }
    f = tmp_path / "gains.json"
    f.write_text(json.dumps(doc))
    return f


def test_the_files_marks_are_what_the_eds_holds():
    for eds in ("master.eds", "slave.eds"):
        keys = set(load_eds(eds_path(eds)).by_key)
        assert set(SDO_GAIN_FIELDS) <= keys and not set(RESTART_GAIN_FIELDS) & keys, eds
    assert apply_marks() == {
        "mode": "telepresence",
        "sdo": ["kp_A_per_C", "ki_A_per_C_s", "kQ_A_per_W"],
        "restart": ["kpQ_A_per_W", "kiQ_A_per_W_s"],
    }


def test_bad_marks_are_refused_with_the_field(cli, tmp_path):
    f = gains_file(tmp_path, apply={"mode": "telepresence", "sdo": ["kp_A_per_C", "kp"], "restart": []})
    code, out, err = cli("apply-gains", "--bus", "virtual:none", str(f), "master")
    assert code == EXIT_USAGE and out == "" and err.count("\n") == 1
    assert err.startswith(
        f"telethermo apply-gains: error: {f}: apply.sdo: expected a list of gain names from "
    )
    f = gains_file(
        tmp_path, apply={"mode": "telepresence", "sdo": ["kp_A_per_C"], "restart": ["kpQ_A_per_W"]}
    )
    code, _, err = cli("apply-gains", "--bus", "virtual:none", str(f))
    assert code == EXIT_USAGE and "apply: sdo and restart must split the gains" in err


@pytest.mark.slow
def test_apply_gains_to_a_running_master(lone_master, cli, tmp_path):
    bus = lone_master[0]
    f = gains_file(tmp_path)
    assert wait_for(lambda: cli("get", "--bus", bus, "--timeout", "0.3", "master", "mode")[0] == EXIT_OK, 30)
    before = cli("get", "--bus", bus, "master", "kp_A_per_C")[1]
    # idle: a write would set idle's gains, not telepresence's: refused, nothing written
    code, out, err = cli("apply-gains", "--bus", bus, str(f), "master")
    assert code == EXIT_FAIL and out == "" and err.count("\n") == 1, (out, err)
    assert err == (
        f"telethermo apply-gains: master is in idle: the file holds telepresence gains and a "
        f"node writes a gain into the mode it is in; nothing written (`telethermo mode "
        f"telepresence` first, or start the nodes with --gains {f})\n"
    )
    assert cli("get", "--bus", bus, "master", "kp_A_per_C")[1] == before
    net = canopen.Network()
    host, port_channel = bus.split("://")[1].split(":", 1)
    port, channel = port_channel.split("/", 1)
    net.connect(interface="socketcand", host=host, port=int(port), channel=channel)
    try:
        assert cli("set", "--bus", bus, "master", "mode", "telepresence")[0] == EXIT_OK
        code, out, err = cli("apply-gains", "--bus", bus, str(f), "master")
        assert code == EXIT_OK, err
        lines = out.splitlines()
        assert [ln.split(" = ")[0] for ln in lines[:3]] == [
            "master 0x2200 kp_A_per_C",
            "master 0x2201 ki_A_per_C_s",
            "master 0x2202 kQ_A_per_W",
        ]
        assert lines[3:] == [
            f"needs a node start with --gains {f} (no object to write): "
            "master kpQ_A_per_W = 0.5, master kiQ_A_per_W_s = 0.25"
        ]
        node = net.add_node(canopen.RemoteNode(1, str(eds_path("master.eds"))))  # not our client
        assert {k: node.sdo[k].raw for k in SDO_GAIN_FIELDS} == {k: TUNED[k] for k in SDO_GAIN_FIELDS}
    finally:
        back = cli("set", "--bus", bus, "master", "mode", "idle")
        net.disconnect()
    assert back[0] == EXIT_OK, back
    # the gains went to telepresence's set: idle runs its own again
    assert cli("get", "--bus", bus, "master", "kp_A_per_C")[1] == before


def test_an_out_of_range_gain_is_refused_before_the_bus_saying_not_sent_once(cli, tmp_path):
    f = gains_file(tmp_path)
    doc = json.loads(f.read_text())
    doc["master"]["kp_A_per_C"] = 50.0  # the file format takes it, the EDS range does not
    f.write_text(json.dumps(doc))
    code, out, err = cli("apply-gains", "--bus", "virtual:none", str(f), "master")
    assert code == EXIT_USAGE and out == "" and err.count("\n") == 1, (out, err)
    assert f"{f}: master.kp_A_per_C: kp_A_per_C = 50 is out of range [" in err
    assert err.rstrip().endswith("; not sent") and err.count("not sent") == 1, err
