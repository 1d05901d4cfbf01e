"""``monitor --rig-config RIG.toml``: the frames of a real ``telethermo-iomodule`` process (CiA 401, node 3
of bus_config/rig_io_sim.toml), recorded from the hub by a plain python-can client, are decoded by the
module's EDS and named by the rig file (without it: "no mapping known"); the controller's heartbeat is
expected at the period the node lowers it to for its modules (50 ms, not the network file's 100 ms)."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import can
import pytest

from telethermo.bus_config import path as bus_config_path
from telethermo.cli.main import EXIT_OK, EXIT_USAGE, main
from telethermo.iomodule.rigconfig import load_rig_config
from telethermo.nodes.launch import stop_process
from telethermo.transport.hub import HubThread

RIG = bus_config_path("rig_io_sim.toml")
BIN = Path(sys.executable).parent
MODULE = 3


def _record_module(log: Path) -> None:
    """A module process on a hub; NMT start and 30 SYNCs (counter 1..30) from our client; every frame into
    ``log``; a heartbeat of the master (node 1) at the end, as a controller on that bus would send."""
    with HubThread() as hub:
        proc = subprocess.Popen(
            [
                str(BIN / "telethermo-iomodule"),
                "--node-id",
                str(MODULE),
                "--bus",
                f"socketcand://127.0.0.1:{hub.port}/vcan0",
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        try:
            assert "ready" in proc.stdout.readline()
            bus = can.Bus(interface="socketcand", host="127.0.0.1", port=hub.port, channel="vcan0")
            writer = can.Logger(str(log))
            seen: list[can.Message] = []
            notifier = can.Notifier(bus, [writer, seen.append])
            try:
                bus.send(can.Message(arbitration_id=0, data=[0x01, MODULE], is_extended_id=False))
                for k in range(30):  # with the counter network.toml's SYNC carries (a 0-byte SYNC is an EMCY)
                    time.sleep(0.02)
                    bus.send(can.Message(arbitration_id=0x80, data=[k + 1], is_extended_id=False))
                deadline = time.monotonic() + 30
                while not any(m.arbitration_id == 0x180 + MODULE for m in seen):
                    assert time.monotonic() < deadline, "no TPDO1 from the module"
                    time.sleep(0.05)
                bus.send(can.Message(arbitration_id=0x701, data=[0x05], is_extended_id=False))
                time.sleep(0.2)
            finally:
                notifier.stop()
                writer.stop()
                bus.shutdown()
        finally:
            stop_process(proc)


@pytest.fixture(scope="module")
def module_log(tmp_path_factory):
    log = tmp_path_factory.mktemp("rig") / "module.log"
    _record_module(log)
    return log


def _replay(log: Path, capsys, *extra: str) -> tuple[list[dict], dict]:
    code = main(["monitor", "--replay", str(log), "--json", *extra])
    out = capsys.readouterr().out.strip().splitlines()
    assert code == EXIT_OK
    frames = [json.loads(ln) for ln in out if '"type":"frame"' in ln]
    return frames, json.loads(out[-1])


@pytest.mark.slow  # a module process on the hub
def test_a_module_is_decoded_by_the_rig_file(module_log, capsys):
    frames, status = _replay(module_log, capsys, "--rig-config", str(RIG))
    tpdos = [f for f in frames if f["cob_id"] == 0x180 + MODULE]
    assert tpdos
    assert all(f["text"].startswith(f"TPDO1 node {MODULE}:") for f in tpdos)
    assert all("no mapping known" not in f["text"] for f in tpdos)
    assert all(t.count("=") == 4 for t in (f["text"] for f in tpdos))  # the EDS maps 4 analogue inputs
    nodes = {n["node"]: n for n in status["nodes"]}
    assert nodes[MODULE]["name"] == "io" and nodes[MODULE]["nmt_state"] == "OPERATIONAL"
    limit_s = load_rig_config(RIG).heartbeat_limit_ms / 1000.0
    assert limit_s == pytest.approx(0.05)
    assert nodes[1]["producer_time_s"] == pytest.approx(limit_s)


@pytest.mark.slow
def test_without_the_rig_file_the_module_is_undecoded_and_the_master_beats_at_100_ms(module_log, capsys):
    frames, status = _replay(module_log, capsys)
    tpdos = [f for f in frames if f["cob_id"] == 0x180 + MODULE]
    assert tpdos and all("no mapping known" in f["text"] and "--rig-config" in f["text"] for f in tpdos)
    assert {n["node"]: n for n in status["nodes"]}[1]["producer_time_s"] == pytest.approx(0.1)


def test_a_bad_rig_file_is_one_line(tmp_path, capsys):
    bad = tmp_path / "RIG.toml"
    bad.write_text('[modules.io]\nnode_id = "three"\n')
    log = tmp_path / "empty.log"
    can.Logger(str(log)).stop()
    code = main(["monitor", "--replay", str(log), "--json", "--rig-config", str(bad)])
    err = capsys.readouterr().err
    assert code == EXIT_USAGE and len(err.strip().splitlines()) == 1
    assert str(bad) in err and "node_id" in err
