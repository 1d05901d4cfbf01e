"""Settings that survive a restart (issue 24 item 5): CiA 301 store (0x1010) and restore defaults (0x1011)
on the master program, a real process on our hub, driven by canopen's own RemoteNode/SdoClient from the
shipped EDS and by raw NMT frames; the node program is stopped and started again between the steps.

A gain written by SDO and saved reads back after a restart (with a communication object and the model
the node ran); a store file that does not check is refused at boot in one line naming it, and the node
runs on its defaults; restore-defaults brings the defaults back at the next reset and start; a wrong
signature is refused with 0x08000020. `telethermo save` / `restore-defaults` do the same from the CLI."""

from __future__ import annotations

import json
import struct
import subprocess
import threading
from pathlib import Path

import can
import canopen
import pytest
from canopen.sdo import SdoAbortedError

from telethermo.bus_config import path as bus_config_path
from telethermo.cli.main import main as cli_main
from telethermo.device import load_network
from telethermo.ident import default_model_path
from telethermo.nodes.launch import node_command, stop_process, wait_for
from telethermo.transport.hub import HubThread

pytestmark = pytest.mark.slow  # starts processes

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "sim" / "scenes" / "free_pad_identification.toml"
MODEL = default_model_path()  # the shipped model of the simulated rig
MASTER = load_network().node("master").node_id  # the shipped network.toml's, as the program uses
SAVE, LOAD = b"save", b"load"  # CiA 301 signatures as sent: 0x65766173, 0x64616F6C little-endian


def f32(x: float) -> float:
    return struct.unpack("<f", struct.pack("<f", x))[0]


class Bootups(can.Listener):
    def __init__(self) -> None:
        self.count = 0
        self.lock = threading.Lock()

    def on_message_received(self, msg: can.Message) -> None:
        if msg.arbitration_id == 0x700 + MASTER and bytes(msg.data) == b"\x00":
            with self.lock:
                self.count += 1


@pytest.fixture
def rig(tmp_path):
    """A hub, a canopen client on it and a way to (re)start the master program with a --store file."""
    with HubThread() as hub:
        bus = f"socketcand://127.0.0.1:{hub.port}/telethermo"
        net = canopen.Network(
            can.Bus(
                interface="socketcand", host="127.0.0.1", port=hub.port, channel="telethermo", tcp_tune=True
            )
        )
        net.connect()
        boots = Bootups()
        net.notifier.add_listener(boots)
        remote = canopen.RemoteNode(MASTER, str(bus_config_path("master.eds")))
        net.add_node(remote)
        remote.sdo.RESPONSE_TIMEOUT = 5.0

        class Rig:
            store = tmp_path / "state" / "node1.json"
            sdo = remote.sdo
            proc: subprocess.Popen | None = None
            stderr = tmp_path / "master-stderr.log"
            bus_text = bus

            def start(self, *extra: str) -> None:
                n = boots.count
                self.stderr.write_bytes(b"")
                self.proc = subprocess.Popen(
                    node_command(
                        "master",
                        "--bus",
                        bus,
                        "--scene",
                        str(SCENE),
                        "--no-sync",
                        "--mode",
                        "idle",
                        "--cycles",
                        "0",
                        "--store",
                        str(self.store),
                        "--log",
                        str(tmp_path / "m.log"),
                        *extra,
                    ),
                    stdout=subprocess.DEVNULL,
                    stderr=open(self.stderr, "wb"),
                )
                assert wait_for(lambda: boots.count > n or self.proc.poll() is not None, 60), "no boot-up"
                assert self.proc.poll() is None, self.stderr.read_text()

            def stop(self) -> None:
                assert stop_process(self.proc) == 0, self.stderr.read_text()

            def reset_node(self) -> None:
                n = boots.count
                net.send_message(0, bytes([0x81, MASTER]))
                assert wait_for(lambda: boots.count > n, 30), "no boot-up after reset node"

            def u32(self, index: int, sub: int) -> int:
                return int.from_bytes(self.sdo.upload(index, sub), "little")

        r = Rig()
        try:
            yield r
        finally:
            stop_process(r.proc)
            net.disconnect()


def test_a_saved_gain_survives_a_restart_and_a_corrupted_store_is_refused(rig):
    rig.start("--model", str(MODEL))
    kp = rig.sdo["kp_A_per_C"]
    default_kp = kp.raw
    assert rig.sdo[0x1010][1].raw == 1 and rig.sdo[0x1011][3].raw == 1  # capability: saves on command
    assert rig.sdo["store_state"].raw == 0 and not rig.store.exists()
    new_kp = f32(default_kp * 1.5 + 0.1)
    kp.raw = new_kp
    rig.sdo["T_max_C"].raw = 40.5
    rig.sdo[0x1017].raw = 150  # a communication parameter
    crc = rig.sdo["model_crc32"].raw
    assert crc != 0
    rig.sdo.download(0x1010, 1, SAVE)
    assert rig.sdo[0x1010][1].raw == 1  # reads its capability again
    assert rig.sdo["store_state"].raw == 3 and rig.sdo["store_file"].raw == str(rig.store)
    doc = json.loads(rig.store.read_text())
    assert doc["node_id"] == MASTER and doc["crc32"].startswith("0x")
    rig.stop()

    rig.start()  # no --model this time
    assert rig.sdo["kp_A_per_C"].raw == new_kp
    assert rig.sdo["T_max_C"].raw == f32(40.5)
    assert rig.sdo[0x1017].raw == 150
    assert rig.sdo["model_status"].raw == 1 and rig.sdo["model_crc32"].raw == crc
    assert rig.sdo["store_state"].raw == 1 and rig.sdo["store_saved_unix_s"].raw == int(doc["saved_unix_s"])
    rig.stop()

    text = rig.store.read_text()  # damage one stored value
    rig.store.write_text(text.replace(json.dumps(new_kp), json.dumps(new_kp + 1.0), 1))
    assert rig.store.read_text() != text
    rig.start()
    lines = [ln for ln in rig.stderr.read_text().splitlines() if "store" in ln]
    assert len(lines) == 1 and str(rig.store) in lines[0], lines
    assert "crc32" in lines[0] and "defaults" in lines[0], lines
    assert rig.sdo["kp_A_per_C"].raw == default_kp and rig.sdo[0x1017].raw == 100
    assert rig.sdo["model_status"].raw == 0 and rig.sdo["store_state"].raw == 2
    rig.stop()

    rig.store.write_text(text[: len(text) // 2])  # cut short: not JSON
    rig.start()
    lines = [ln for ln in rig.stderr.read_text().splitlines() if "store" in ln]
    assert len(lines) == 1 and str(rig.store) in lines[0] and "not valid JSON" in lines[0], lines
    assert rig.sdo["kp_A_per_C"].raw == default_kp and rig.sdo["store_state"].raw == 2


def test_restore_defaults_takes_effect_at_the_next_reset_and_start(rig):
    rig.start()
    kp = rig.sdo["kp_A_per_C"]
    default_kp = kp.raw
    kp.raw = f32(default_kp + 0.25)
    rig.sdo.download(0x1010, 3, SAVE)  # application parameters only
    rig.reset_node()  # reset node restores the store
    assert rig.sdo["kp_A_per_C"].raw == f32(default_kp + 0.25)
    assert rig.sdo["store_state"].raw == 1
    rig.sdo.download(0x1011, 1, LOAD)
    assert rig.sdo[0x1011][1].raw == 1
    assert rig.sdo["kp_A_per_C"].raw == f32(default_kp + 0.25)  # not before the next reset
    assert rig.sdo["store_state"].raw == 4 and not rig.store.exists()
    rig.reset_node()
    assert rig.sdo["kp_A_per_C"].raw == default_kp and rig.sdo["store_state"].raw == 0
    rig.stop()
    rig.start()
    assert rig.sdo["kp_A_per_C"].raw == default_kp and rig.sdo["store_state"].raw == 0


def test_a_wrong_signature_is_refused_with_0x08000020(rig):
    rig.start()
    wrong = ((0x1010, 1, LOAD), (0x1010, 2, b"SAVE"), (0x1011, 3, SAVE), (0x1011, 1, bytes(4)))
    for index, sub, data in wrong:
        with pytest.raises(SdoAbortedError) as exc:
            rig.sdo.download(index, sub, data)
        assert exc.value.code == 0x08000020, (hex(index), sub)
        assert rig.sdo[index][sub].raw == 1
    assert not rig.store.exists() and rig.sdo["store_state"].raw == 0


def test_the_cli_saves_and_restores_defaults(rig, capsys):
    rig.start()
    default_kp = rig.sdo["kp_A_per_C"].raw
    assert cli_main(["set", "--bus", rig.bus_text, "master", "kp_A_per_C", str(default_kp + 0.5)]) == 0
    assert cli_main(["save", "--bus", rig.bus_text, "master"]) == 0
    out = capsys.readouterr().out
    assert "master (node 1): all parameters saved" in out and str(rig.store) in out
    assert "3 (yes - saved)" in out
    rig.stop()
    rig.start()
    assert rig.sdo["kp_A_per_C"].raw == f32(default_kp + 0.5)
    assert cli_main(["status", "--bus", rig.bus_text, "master"]) == 0
    out = capsys.readouterr().out
    assert "1 (yes - restored at boot)" in out and str(rig.store) in out and " UTC" in out
    assert cli_main(["restore-defaults", "--bus", rig.bus_text, "master"]) == 0
    assert "next reset" in capsys.readouterr().out
    rig.stop()
    rig.start()
    assert rig.sdo["kp_A_per_C"].raw == default_kp
