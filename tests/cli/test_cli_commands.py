"""The operator CLI against two real CiA 301 devices on a virtual bus (in-process, no mocks)."""

from __future__ import annotations

import json

import can
import pytest

from telethermo.cli.main import EXIT_FAIL, EXIT_OK, EXIT_USAGE
from telethermo.control.render_table import load_render_table


def test_find_lists_both_nodes_with_identity_and_name(nodes, cli):
    code, out, err = cli("find", *nodes.bus, "--json")
    assert code == EXIT_OK, err
    doc = json.loads(out)
    by = {n["role"]: n for n in doc["nodes"]}
    assert set(by) == {"master", "slave"} and doc["missing"] == []
    for role, dev in nodes.devices.items():
        n = by[role]
        assert n["node_id"] == dev.node_id and n["answers_sdo"] and n["heartbeats"] >= 1
        assert n["nmt_state"] == "PRE-OPERATIONAL"
        assert n["device_name"] == dev.read("Manufacturer device name")
        assert n["vendor_id"] == dev.read((0x1018, 1)) and n["product_code"] == dev.read((0x1018, 2))


def test_set_in_range_then_out_of_range_refused_locally_and_by_the_node(nodes, cli):
    code, out, err = cli("set", *nodes.bus, "master", "kp_A_per_C", "1.25")
    assert code == EXIT_OK, err
    assert "kp_A_per_C = 1.25 A/degC" in out and "[0, 20] A/degC" in out
    assert nodes.devices["master"].read("kp_A_per_C") == pytest.approx(1.25)
    # out of the EDS range: refused here, nothing sent, the range shown
    code, out, err = cli("set", *nodes.bus, "master", "kp_A_per_C", "25")
    assert code == EXIT_USAGE and "out of range [0, 20] A/degC; not sent" in err and "Traceback" not in err
    assert nodes.devices["master"].read("kp_A_per_C") == pytest.approx(1.25)
    # a write the node refuses (read-only object, sent by number to bypass the local check)
    code, out, err = cli("set", *nodes.bus, "slave", "0x1018:1", "5")
    assert code == EXIT_USAGE and "read-only" in err
    code, out, err = cli("get", *nodes.bus, "slave", "kp_A_per_C", "ki_A_per_C_s", "mode")
    assert code == EXIT_OK and "kp_A_per_C = 0.5 A/degC" in out and "mode = 0" in out


def test_node_refusal_shows_abort_code_and_meaning(nodes, cli, tmp_path):
    """The operator's EDS is out of date (T_max_C up to 60 °C): the local check passes, the node
    (whose envelope stops at 43 °C) refuses, and the CLI shows the abort code and its meaning."""
    import re
    import shutil
    from telethermo.bus_config import path as cfg_path

    eds = (cfg_path("master.eds")).read_text()
    eds = re.sub(r"(\[2401\][^\[]*?HighLimit=)43\.0", r"\g<1>60.0", eds, flags=re.S)
    assert "HighLimit=60.0" in eds
    (tmp_path / "master.eds").write_text(eds)
    shutil.copy(cfg_path("slave.eds"), tmp_path / "slave.eds")
    (tmp_path / "network.toml").write_text(cfg_path("network.toml").read_text())
    code, out, err = cli(
        "set", *nodes.bus, "--network", str(tmp_path / "network.toml"), "master", "T_max_C", "50"
    )
    assert code == EXIT_FAIL
    assert err.startswith(
        "telethermo set: master (node 1) refused T_max_C = 50.0: "
        "SDO abort 0x06090031: Value of parameter written too high (download only); "
        "the node's limit is narrower than this EDS's range [15, 60] degC (T_max_C in "
    )
    assert err.endswith("master.eds: out of date?)\n") and err.count("\n") == 1
    assert nodes.devices["master"].read("T_max_C") == pytest.approx(43.0)


def test_unknown_names_and_nodes_are_one_line_usage_errors(nodes, cli):
    code, _, err = cli("get", *nodes.bus, "master", "kp")
    assert code == EXIT_USAGE and "no object named 'kp'; did you mean kp_A_per_C" in err
    assert len(err.strip().splitlines()) == 1
    code, _, err = cli("get", *nodes.bus, "nobody", "mode")
    assert code == EXIT_USAGE and "unknown node 'nobody'" in err and "master (1)" in err
    code, _, err = cli("set", *nodes.bus, "master", "kp_A_per_C", "fast")
    assert code == EXIT_USAGE and "expected a REAL32 value, got 'fast'" in err


def test_nmt_stop_start_and_reset_confirmed_by_heartbeat(nodes, cli):
    code, out, err = cli("nmt", *nodes.bus, "start")
    assert code == EXIT_OK, err
    assert "master (node 1): OPERATIONAL" in out and "slave (node 2): OPERATIONAL" in out
    code, out, err = cli("nmt", *nodes.bus, "stop", "slave")
    assert code == EXIT_OK and "slave (node 2): STOPPED" in out
    assert int(nodes.devices["slave"].state) == 4 and int(nodes.devices["master"].state) == 5
    code, out, err = cli("nmt", *nodes.bus, "reset", "master")
    assert code == EXIT_OK and "master (node 1): boot-up seen" in out
    assert int(nodes.devices["master"].state) == 0x7F


def test_status_reads_mode_temperatures_safety_and_nmt(nodes, cli):
    nodes.devices["master"].write("mode", 1, check=False)
    code, out, err = cli("status", *nodes.bus, "--json")
    assert code == EXIT_OK, err
    doc = {n["role"]: n for n in json.loads(out)["nodes"]}
    assert doc["master"]["values"]["mode"] == 1 and doc["slave"]["values"]["mode"] == 0
    for role in ("master", "slave"):
        v = doc[role]["values"]
        assert {"T_sensor_C", "estimate_C", "Q_W", "current_A", "safety_state", "late_cycles"} <= set(v)
        assert doc[role]["units"]["T_sensor_C"] == "degC" and doc[role]["nmt_state"] == "PRE-OPERATIONAL"
    # a value the node reports as NaN is null in the JSON (issue 25: it was the string "nan")
    nodes.devices["master"].write("T_pred_C", float("nan"), check=False)
    code, out, err = cli("status", *nodes.bus, "--json", "master")
    assert (
        code == EXIT_OK and '"nan"' not in out and json.loads(out)["nodes"][0]["values"]["T_pred_C"] is None
    )
    code, out, _ = cli("status", *nodes.bus, "master")
    assert (
        "mode            1 (telepresence)" in out and "safety          0 (ok)" in out
    )  # as `get` shows them


def test_mode_render_writes_material_beta_and_mode(nodes, cli):
    code, out, err = cli("mode", *nodes.bus, "render", "brass", "--object-temp", "24")
    assert code == EXIT_OK, err
    m = nodes.devices["master"]
    assert m.read("mode") == 2 and m.read("material_beta") == pytest.approx(5.60, rel=1e-6)
    assert m.read("object_T0_C") == pytest.approx(24.0)
    assert m.read("material_code") == 1 + list(load_render_table()).index("brass")  # not 0 (custom)
    # the slave is set to idle, and the operator is told
    assert nodes.devices["slave"].read("mode") == 0
    assert (
        "slave (node 2): mode idle (while the master renders alone; `telethermo mode telepresence` couples "
        "both again)"
    ) in out.splitlines()
    code, out, err = cli("mode", *nodes.bus, "telepresence")
    assert code == EXIT_OK and nodes.devices["slave"].read("mode") == 1 and m.read("mode") == 1
    code, out, err = cli("mode", *nodes.bus, "render", "wood")
    assert code == EXIT_OK and m.read("material_code") == 1 + list(load_render_table()).index("wood")
    assert out.splitlines()[-1] == f"mode: render wood (β = 0.74, material_code {m.read('material_code')})"
    code, out, err = cli("mode", *nodes.bus, "render", "--beta", "3")
    assert code == EXIT_OK and m.read("material_code") == 0 and m.read("material_beta") == pytest.approx(3)
    assert out.splitlines()[-1] == "mode: render custom (β = 3, material_code 0 custom)"
    code, _, err = cli("mode", *nodes.bus, "render", "unobtainium")
    assert code == EXIT_USAGE and "brass" in err and "wood" in err
    code, _, err = cli("mode", *nodes.bus, "render", "--beta", "5000")
    assert code == EXIT_USAGE and "material_beta = 5000 is out of range [0.001, 1000]" in err


def test_silent_node_is_a_runtime_failure(cli):
    code, out, err = cli("get", "--bus", "virtual:tt-cli-nobody-here", "--timeout", "0.1", "master", "mode")
    assert code == EXIT_FAIL and "master (node 1) did not answer reading mode" in err
    code, out, err = cli("find", "--bus", "virtual:tt-cli-nobody-here")
    assert code == EXIT_FAIL and "no CANopen node found" in err


@pytest.mark.parametrize("ext", [".log", ".asc", ".blf"])
def test_record_writes_a_log_that_logreader_reads_back_whole(nodes, cli, tmp_path, ext):
    import threading
    import time

    out_file = tmp_path / f"rec{ext}"
    sender = can.Bus(interface="virtual", channel=nodes.channel)
    stop = threading.Event()

    def send():  # SYNC with a running counter until the recording is over
        k = 0
        while not stop.is_set():
            sender.send(can.Message(arbitration_id=0x080, data=[k % 240 + 1], is_extended_id=False))
            k += 1
            time.sleep(0.002)  # paces the SYNC stream on purpose (a bus at ~500 frames/s)

    th = threading.Thread(target=send)
    th.start()
    try:
        # stopped by a frame count, not a wall-clock window: a loaded machine may deliver few frames
        # in 0.8 s; --duration only bounds the test if the frames never come
        code, out, err = cli(
            "record", "--bus", f"virtual:{nodes.channel}", str(out_file), "--count", "60", "--duration", "60"
        )
    finally:
        stop.set()
        th.join()
        sender.shutdown()
    assert code == EXIT_OK, err
    n = int(out.split()[1])
    assert n == 60
    back = list(can.LogReader(str(out_file)))
    assert len(back) == n
    counters = [m.data[0] for m in back if m.arbitration_id == 0x080]
    assert len(counters) >= 2
    assert all(b == a % 240 + 1 for a, b in zip(counters, counters[1:]))  # none lost, in order
    assert {m.arbitration_id for m in back} <= {0x080, 0x701, 0x702}
    rows = (tmp_path / f"rec{ext}.csv").read_text().splitlines()
    assert len(rows) == n + 1 and rows[0].startswith("t_s,cob_id,kind")
    assert sum(1 for r in rows if ",SYNC," in r) == len(counters)


def test_record_refuses_unknown_extension(cli, tmp_path):
    code, _, err = cli("record", str(tmp_path / "x.mp3"))
    assert code == EXIT_USAGE and "unsupported log format '.mp3'" in err and ".blf" in err
