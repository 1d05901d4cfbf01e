"""The CLI against the live node programs: two OS processes (telethermo-master, telethermo-slave)
with simulated rigs in real time, over our socketcand hub, as an operator would use it."""
from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import can
import pytest

from bus_config import path as cfg_path
from nodes.launch import NodePair, PairConfig, wait_for
from telethermo.cli.main import EXIT_FAIL, EXIT_OK, EXIT_USAGE

pytestmark = pytest.mark.slow
SCENE = Path(__file__).resolve().parents[2] / "sim" / "scenes" / "probe_touches_al_steel_wood.toml"


@pytest.fixture(scope="module")
def live(tmp_path_factory):
    out = tmp_path_factory.mktemp("live")
    pair = NodePair(PairConfig(scene=SCENE, out_dir=out, timing="realtime", cycles=0, progress_every=1000))
    pair.start()
    try:
        yield pair
    finally:
        pair.stop()


def run_cli(capsys, *argv):
    from telethermo.cli.main import main
    code = main(list(argv))
    o = capsys.readouterr()
    return code, o.out, o.err


def status(capsys, bus):
    code, out, err = run_cli(capsys, "status", "--bus", bus, "--json")
    assert code == EXIT_OK, err
    return {n["role"]: n for n in json.loads(out)["nodes"]}


def both_operational(capsys, bus) -> bool:
    """True once both nodes answer and their heartbeats say OPERATIONAL (they take a while to start)."""
    code, out, _ = run_cli(capsys, "status", "--bus", bus, "--json", "--timeout", "0.2")
    return code == EXIT_OK and all(n["nmt_state"] == "OPERATIONAL" for n in json.loads(out)["nodes"])


def test_find_status_set_nmt_mode_record(live, capsys, tmp_path):
    bus = live.bus
    # find: both nodes, OPERATIONAL once the master has started the session
    assert wait_for(lambda: both_operational(capsys, bus), 30)
    code, out, err = run_cli(capsys, "find", "--bus", bus, "--json")
    assert code == EXIT_OK, err
    found = {n["role"]: n for n in json.loads(out)["nodes"]}
    assert found["master"]["device_name"] == "telethermo master" and found["slave"]["node_id"] == 2

    # status: telepresence, real time, cycles running, temperatures plausible for a lab
    st = status(capsys, bus)
    for role in ("master", "slave"):
        v = st[role]["values"]
        assert v["mode"] == 1 and v["lockstep"] is False and v["peer_alive"] is True
        assert 15.0 < v["T_sensor_C"] < 43.0 and 15.0 < v["estimate_C"] < 43.0
        assert st[role]["units"]["Q_W"] == "W"
    c0 = st["master"]["values"]["cycle_counter"]
    assert wait_for(lambda: status(capsys, bus)["master"]["values"]["cycle_counter"] > c0, 5)

    # set: accepted, refused locally, refused by the node (an out-of-date EDS on the operator's side)
    code, out, err = run_cli(capsys, "set", "--bus", bus, "slave", "kp_A_per_C", "0.75")
    assert code == EXIT_OK and "kp_A_per_C = 0.75 A/degC" in out, err
    code, out, _ = run_cli(capsys, "get", "--bus", bus, "slave", "kp_A_per_C")
    assert "kp_A_per_C = 0.75 A/degC" in out
    code, _, err = run_cli(capsys, "set", "--bus", bus, "master", "T_max_C", "50")
    assert code == EXIT_USAGE and "out of range [15, 43] degC; not sent" in err
    eds = re.sub(r"(\[2401\][^\[]*?HighLimit=)43\.0", r"\g<1>60.0", cfg_path("master.eds").read_text(), flags=re.S)
    (tmp_path / "master.eds").write_text(eds)
    shutil.copy(cfg_path("slave.eds"), tmp_path / "slave.eds")
    shutil.copy(cfg_path("network.toml"), tmp_path / "network.toml")
    code, _, err = run_cli(capsys, "set", "--bus", bus, "--network", str(tmp_path / "network.toml"),
                           "master", "T_max_C", "50")
    assert code == EXIT_FAIL and "SDO abort 0x06090031: Value of parameter written too high" in err

    # NMT stop / start of the slave, confirmed by its heartbeat
    code, out, err = run_cli(capsys, "nmt", "--bus", bus, "stop", "slave")
    assert code == EXIT_OK and "slave (node 2): STOPPED" in out, err
    code, out, err = run_cli(capsys, "nmt", "--bus", bus, "start", "slave")
    assert code == EXIT_OK and "slave (node 2): OPERATIONAL" in out, err

    # mode change: idle on both, then back to telepresence
    code, out, err = run_cli(capsys, "mode", "--bus", bus, "idle")
    assert code == EXIT_OK and "master (node 1): mode idle" in out and "slave (node 2): mode idle" in out, err
    assert {n: s["values"]["mode"] for n, s in status(capsys, bus).items()} == {"master": 0, "slave": 0}
    code, out, err = run_cli(capsys, "mode", "--bus", bus, "telepresence")
    assert code == EXIT_OK, err

    # record: the real console script, a BLF that can.LogReader reads back whole
    log = tmp_path / "session.blf"
    p = subprocess.run([sys.executable, "-m", "telethermo.cli.main", "record", "--bus", bus, str(log),
                        "--duration", "1.0"], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    n = int(re.search(r"recorded (\d+) frames", p.stdout).group(1))
    back = list(can.LogReader(str(log)))
    assert len(back) == n
    counters = [m.data[0] for m in back if m.arbitration_id == 0x080]
    assert len(counters) >= 2
    assert all(b == a % 240 + 1 for a, b in zip(counters, counters[1:]))   # no SYNC lost
    rows = log.with_suffix(".csv").read_text().splitlines()
    assert len(rows) == n + 1 and any(",PDO," in r and "estimate_C" in r for r in rows)


def test_monitor_json_on_the_live_session(live, capsys):
    assert wait_for(lambda: both_operational(capsys, live.bus), 30)
    code, out, err = run_cli(capsys, "monitor", "--bus", live.bus, "--json", "--no-frames", "--duration", "1.5",
                             "--status-every", "0")
    assert code == EXIT_OK, err
    snap = [json.loads(ln) for ln in out.splitlines() if '"type":"status"' in ln][-1]
    assert [n["nmt_state"] for n in snap["nodes"]] == ["OPERATIONAL", "OPERATIONAL"]
    assert snap["syncs"] >= 2 and snap["sync_counter_errors"] == 0
    pdos = {(p["node"], p["pdo"]): p for p in snap["pdos"]}
    assert [v["name"] for v in pdos[(1, "TPDO1")]["values"]] == ["estimate_C", "Q_W"]
    assert [v["unit"] for v in pdos[(2, "TPDO1")]["values"]] == ["degC", "W"]
    for node in (1, 2):   # one TPDO1 per SYNC from each node (up to the window's two ends)
        assert abs(pdos[(node, "TPDO1")]["count"] - snap["syncs"]) <= 1
    assert snap["error_frames"] == 0 and snap["unknown_frames"] == 0 and snap["malformed"] == 0


def test_calibrate_finger_live_on_the_rendering_master(tmp_path, capsys):
    """yamamoto's per-user step on the live master (the display alone, scene virtual_materials: the
    simulated finger touches at 5 s with the pad pre-set for EPS). One touch with the finger's
    temperature given (yamamoto measures it with a radiation thermometer): the contact temperature
    must lie between the pad's and the finger's (eq. 1), β_pad = (T_f0 - T_c)/(T_c - T_pad0) must
    come out positive and be written into the node."""
    from nodes.launch import HubProcess, node_command, stop_process
    hub = HubProcess(idle_timeout_s=60)
    hub.start()
    scene = SCENE.parent / "virtual_materials.toml"
    master = subprocess.Popen(node_command("master", "--bus", hub.bus, "--scene", str(scene), "--timing", "realtime",
                                           "--mode", "render", "--log", str(tmp_path / "m.log")),
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    tf0 = 34.0
    try:
        assert wait_for(lambda: run_cli(capsys, "get", "--bus", hub.bus, "--timeout", "0.2", "master", "mode")[0]
                        == EXIT_OK, 30)     # the node is up (its scene's first touch is at 5 s)
        code, out, err = run_cli(capsys, "calibrate-finger", "--bus", hub.bus, "--live", "1", "--finger-temp",
                                 str(tf0), "--touch-timeout", "30", "--apply")
        assert code == EXIT_OK, err
        ((p0, c),) = [tuple(map(float, m)) for m in re.findall(r"T_pad0 ([\d.]+) °C -> T_contact ([\d.]+) °C", out)]
        assert min(p0, tf0) < c < max(p0, tf0)                    # eq. 1: between pad and finger
        beta = float(re.search(r"beta_pad = ([\d.]+)", out).group(1))
        h = 0.0005   # the temperatures are printed to 3 decimals: β_pad from eq. 1 within that box
        lo, hi = sorted([(tf0 - (c + h)) / ((c + h) - (p0 - h)), (tf0 - (c - h)) / ((c - h) - (p0 + h))])
        assert lo - 1e-4 <= beta <= hi + 1e-4                      # eq. 1 solved for β_pad
        code, out, err = run_cli(capsys, "get", "--bus", hub.bus, "master", "pad_beta", "finger_T0_C")
        assert code == EXIT_OK, err
        assert float(re.search(r"pad_beta = ([\d.]+)", out).group(1)) == pytest.approx(beta, abs=1e-3)
        assert "finger_T0_C = 34 degC" in out
    finally:
        stop_process(master)
        hub.stop()


def test_monitor_keeps_up_with_a_lockstep_session(tmp_path):
    """`telethermo monitor --json` as a third process on the hub while the two node processes run
    1000 lockstep cycles as fast as they can: every SYNC and every TPDO1 of both nodes is decoded,
    none is counted missing, the SYNC counter never jumps. Stopped with Ctrl-C (SIGINT) like a
    person would: exit 130, the final status still printed."""
    import signal
    from nodes.launch import HubProcess, stop_process
    hub = HubProcess(idle_timeout_s=60)
    hub.start()
    out = tmp_path / "mon.jsonl"
    mon = subprocess.Popen([sys.executable, "-m", "telethermo.cli.main", "monitor", "--bus", hub.bus, "--json",
                            "--no-frames", "--status-every", "0"], stdout=open(out, "w"), stderr=subprocess.PIPE,
                           text=True)
    try:
        time.sleep(1.0)   # the monitor is connected before the nodes boot
        pair = NodePair(PairConfig(scene=SCENE, out_dir=tmp_path / "pair", bus=hub.bus, cycles=1000))
        pair.start()
        try:
            assert pair.wait_master(120) == 0
        finally:
            pair.stop()
        time.sleep(0.5)
        mon.send_signal(signal.SIGINT)
        assert mon.wait(30) == 130
    finally:
        stop_process(mon)
        hub.stop()
    rows = [json.loads(ln) for ln in out.read_text().splitlines()]
    st = [r for r in rows if r["type"] == "status"][-1]
    counts = {(p["node"], p["pdo"]): p["count"] for p in st["pdos"]}
    assert st["syncs"] == 1000 and st["sync_counter_errors"] == 0
    assert counts[(1, "TPDO1")] == 1000 and counts[(2, "TPDO1")] == 1000
    assert st["missed_pdos"] == 0 and st["unknown_frames"] == 0 and st["malformed"] == 0
