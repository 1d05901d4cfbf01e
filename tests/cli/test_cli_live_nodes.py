"""The CLI against the live node programs: two OS processes (telethermo-master, telethermo-slave)
with simulated rigs in real time, over our socketcand hub, as an operator would use it."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import can
import pytest

from telethermo.bus_config import path as cfg_path
from telethermo.nodes.launch import NodePair, PairConfig, wait_for
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
    # 1 s per SDO read: status reads about thirty objects of each node, and a node busy starting its session
    # may take longer than 0.2 s for one of them (every poll then failed for 30 s in one clean run)
    code, out, _ = run_cli(capsys, "status", "--bus", bus, "--json", "--timeout", "1")
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
    eds = re.sub(
        r"(\[2401\][^\[]*?HighLimit=)43\.0", r"\g<1>60.0", cfg_path("master.eds").read_text(), flags=re.S
    )
    (tmp_path / "master.eds").write_text(eds)
    shutil.copy(cfg_path("slave.eds"), tmp_path / "slave.eds")
    shutil.copy(cfg_path("network.toml"), tmp_path / "network.toml")
    code, _, err = run_cli(
        capsys, "set", "--bus", bus, "--network", str(tmp_path / "network.toml"), "master", "T_max_C", "50"
    )
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
    p = subprocess.run(
        [
            sys.executable,
            "-m",
            "telethermo.cli.main",
            "record",
            "--bus",
            bus,
            str(log),
            "--count",
            "300",
            "--duration",
            "60",
        ],
        capture_output=True,
        text=True,
        timeout=90,
    )
    assert p.returncode == 0, p.stderr
    n = int(re.search(r"recorded (\d+) frames", p.stdout).group(1))
    assert n == 300  # stopped by the frame count (not a wall-clock window a loaded machine may starve)
    back = list(can.LogReader(str(log)))
    assert len(back) == n
    counters = [m.data[0] for m in back if m.arbitration_id == 0x080]
    assert len(counters) >= 2
    assert all(b == a % 240 + 1 for a, b in zip(counters, counters[1:]))  # no SYNC lost
    rows = (tmp_path / "session.blf.csv").read_text().splitlines()
    assert len(rows) == n + 1 and any(",PDO," in r and "estimate_C" in r for r in rows)


def test_monitor_json_on_the_live_session(live, capsys):
    """The monitor's JSON on the real-time session: states, PDOs by name and unit, one TPDO1 per SYNC.

    One TPDO1 per SYNC is checked on protocol facts, not on the scheduling of the two processes. The
    master sends its TPDO1 right after its own SYNC, so its count is the SYNC count up to the window's
    two ends. The slave answers each SYNC when it gets to it: a loaded slave is several cycles behind
    at one end of the window and not at the other (its TPDO1s are late, none is lost), so its count is
    checked against its own cycle counter instead: between two of its TPDO4 frames (cycle_counter
    c1, c2) it must have sent, and the monitor decoded, exactly c2 - c1 TPDO1 frames."""
    assert wait_for(lambda: both_operational(capsys, live.bus), 30)
    code, out, err = run_cli(
        capsys, "monitor", "--bus", live.bus, "--json", "--duration", "1.5", "--status-every", "0"
    )
    assert code == EXIT_OK, err
    rows = [json.loads(ln) for ln in out.splitlines()]
    snap = [r for r in rows if r["type"] == "status"][-1]
    assert [n["nmt_state"] for n in snap["nodes"]] == ["OPERATIONAL", "OPERATIONAL"]
    assert snap["syncs"] >= 2 and snap["sync_counter_errors"] == 0
    pdos = {(p["node"], p["pdo"]): p for p in snap["pdos"]}
    assert [v["name"] for v in pdos[(1, "TPDO1")]["values"]] == ["estimate_C", "Q_W"]
    assert [v["unit"] for v in pdos[(2, "TPDO1")]["values"]] == ["degC", "W"]
    frames = [r for r in rows if r["type"] == "frame"]
    assert sum(1 for f in frames if f["kind"] == "SYNC") == snap["syncs"]
    assert abs(pdos[(1, "TPDO1")]["count"] - snap["syncs"]) <= 1
    for node in (1, 2):
        seq = [f["fields"] for f in frames if f["kind"] == "PDO" and f["fields"].get("producer") == node]
        assert sum(1 for x in seq if x["pdo"] == "TPDO1") == pdos[(node, "TPDO1")]["count"]
        marks = [
            (i, {v["name"]: v["value"] for v in x["values"]}["cycle_counter"])
            for i, x in enumerate(seq)
            if x["pdo"] == "TPDO4"
        ]
        assert len(marks) >= 2, f"node {node}: fewer than two TPDO4 in the window"
        (i1, c1), (i2, c2) = marks[0], marks[-1]
        assert c2 > c1 and sum(1 for x in seq[i1:i2] if x["pdo"] == "TPDO1") == c2 - c1, (node, c1, c2)
    assert snap["error_frames"] == 0 and snap["unknown_frames"] == 0 and snap["malformed"] == 0


def test_calibrate_finger_live_on_the_rendering_master(tmp_path, capsys):
    """yamamoto's per-user step on the live master (the display alone, scene virtual_materials: the
    simulated finger touches at 5 s with the pad pre-set for EPS). One touch with the finger's
    temperature given (yamamoto measures it with a radiation thermometer): the contact temperature
    must lie between the pad's and the finger's (eq. 1), β_pad = (T_f0 - T_c)/(T_c - T_pad0) must
    come out positive and be written into the node."""
    from telethermo.nodes.launch import HubProcess, node_command, stop_process

    hub = HubProcess(idle_timeout_s=60)
    hub.start()
    scene = SCENE.parent / "virtual_materials.toml"
    master = subprocess.Popen(
        node_command(
            "master",
            "--bus",
            hub.bus,
            "--scene",
            str(scene),
            "--timing",
            "realtime",
            "--mode",
            "render",
            "--log",
            str(tmp_path / "m.log"),
        ),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    tf0 = 34.0
    try:
        assert wait_for(
            lambda: (
                run_cli(capsys, "get", "--bus", hub.bus, "--timeout", "0.2", "master", "mode")[0] == EXIT_OK
            ),
            30,
        )  # the node is up (its scene's first touch is at 5 s)
        code, out, err = run_cli(
            capsys,
            "calibrate-finger",
            "--bus",
            hub.bus,
            "--live",
            "1",
            "--finger-temp",
            str(tf0),
            "--touch-timeout",
            "30",
            "--apply",
        )
        assert code == EXIT_OK, err
        ((p0, c),) = [
            tuple(map(float, m)) for m in re.findall(r"T_pad0 ([\d.]+) °C -> T_contact ([\d.]+) °C", out)
        ]
        assert min(p0, tf0) < c < max(p0, tf0)  # eq. 1: between pad and finger
        beta = float(re.search(r"beta_pad = ([\d.]+)", out).group(1))
        h = 0.0005  # the temperatures are printed to 3 decimals: β_pad from eq. 1 within that box
        lo, hi = sorted([(tf0 - (c + h)) / ((c + h) - (p0 - h)), (tf0 - (c - h)) / ((c - h) - (p0 + h))])
        assert lo - 1e-4 <= beta <= hi + 1e-4  # eq. 1 solved for β_pad
        code, out, err = run_cli(capsys, "get", "--bus", hub.bus, "master", "pad_beta", "finger_T0_C")
        assert code == EXIT_OK, err
        assert float(re.search(r"pad_beta = ([\d.]+)", out).group(1)) == pytest.approx(beta, abs=1e-3)
        assert "finger_T0_C = 34 degC" in out
    finally:
        stop_process(master)
        hub.stop()


PROBE_NODE = 0x7F  # no node of the network: the test's own heartbeats, to synchronise with the monitor


def _probe(bus: str, state: int) -> None:
    """One heartbeat of node PROBE_NODE (NMT state ``state``) on the hub, from a client of our own."""
    from telethermo.transport.bus import open_bus, parse_bus_string

    b = open_bus(parse_bus_string(bus))
    try:
        b.send(can.Message(arbitration_id=0x700 + PROBE_NODE, data=[state], is_extended_id=False))
    finally:
        b.shutdown()


def _monitor_saw(out: Path, state_name: str) -> bool:
    """The monitor's --json output has the probe node's change to ``state_name`` (the monitor flushes
    its output whenever the bus goes idle for 0.1 s)."""
    for ln in out.read_text().splitlines():
        if f'"node":{PROBE_NODE}' in ln and '"kind":"nmt_state"' in ln:
            if json.loads(ln)["fields"]["to"] == state_name:
                return True
    return False


def test_monitor_keeps_up_with_a_lockstep_session(tmp_path):
    """`telethermo monitor --json` as a third process on the hub while the two node processes run
    1000 lockstep cycles as fast as they can: every SYNC and every TPDO1 of both nodes is decoded,
    the SYNC counter never jumps, and a TPDO1 is counted missing only where the session itself let it
    be late (the master's lockstep wait timed out). Stopped with Ctrl-C (SIGINT) like a person would:
    exit 130, the final status still printed.

    Synchronised on frames, not sleeps: the nodes start only once the monitor has decoded a heartbeat
    the test put on the hub (it is connected), and Ctrl-C comes only once it has decoded a second one
    sent after the session (the hub keeps one order for all clients: every frame of the session is
    decoded by then). Under load the monitor took more than the former fixed 1 s to connect and missed
    the first SYNCs."""
    import signal
    from telethermo.nodes.launch import HubProcess, stop_process

    hub = HubProcess(idle_timeout_s=60)
    hub.start()
    out = tmp_path / "mon.jsonl"
    mon = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "telethermo.cli.main",
            "monitor",
            "--bus",
            hub.bus,
            "--json",
            "--no-frames",
            "--status-every",
            "0",
        ],
        stdout=open(out, "w"),
        stderr=subprocess.PIPE,
        text=True,
    )
    pair_dir = tmp_path / "pair"
    try:

        def connected() -> (
            bool
        ):  # a probe until the monitor shows one (frames before it connects are not its)
            _probe(hub.bus, 0x7F)
            return wait_for(lambda: _monitor_saw(out, "PRE-OPERATIONAL"), 0.5)

        assert wait_for(connected, 120, poll_s=0), (
            mon.stderr.read() if mon.poll() is not None else "no probe seen"
        )
        pair = NodePair(PairConfig(scene=SCENE, out_dir=pair_dir, bus=hub.bus, cycles=1000))
        pair.start()
        try:
            assert pair.wait_master(120) == 0
        finally:
            pair.stop()
        _probe(hub.bus, 0x04)  # after every frame of the session on the hub
        assert wait_for(lambda: _monitor_saw(out, "STOPPED"), 120)
        mon.send_signal(signal.SIGINT)
        assert mon.wait(30) == 130
    finally:
        stop_process(mon)
        hub.stop()
    rows = [json.loads(ln) for ln in out.read_text().splitlines()]
    st = [r for r in rows if r["type"] == "status"][-1]
    tpdo1 = {p["node"]: p for p in st["pdos"] if p["pdo"] == "TPDO1"}
    assert st["syncs"] == 1000 and st["sync_counter_errors"] == 0
    assert tpdo1[1]["count"] == 1000 and tpdo1[2]["count"] == 1000
    assert st["unknown_frames"] == 0 and st["malformed"] == 0
    # Missing TPDO1s: the master sends its TPDO1 after its own SYNC and before the next one, so none of
    # its own can be missing. The slave's TPDO1 k comes before SYNC k+1 unless the master stopped waiting
    # for it (a lockstep timeout after half the consumer time, logged by the master: under load the
    # session itself is late then, the monitor is right to count it) or took the peer for lost.
    master_log = (pair_dir / "master.log").read_text()
    timeouts = len(re.findall(r"no PDO of node 2 within", master_log))
    peer_lost = "peer 2 lost" in master_log
    assert tpdo1[1]["missing"] == 0
    assert st["missed_pdos"] == tpdo1[1]["missing"] + tpdo1[2]["missing"]  # only TPDO1 is on every SYNC
    if not peer_lost:
        assert tpdo1[2]["missing"] <= timeouts, (tpdo1[2]["missing"], timeouts)
