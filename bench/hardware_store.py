"""Real-hardware figures of issue 24 into ``bench/results/hardware.json``, merged: each part updates its own
keys and keeps the others (the I/O-module figures come from another part of this file's future).

``store`` (:func:`store_restore`): the CiA 301 store/restore round trip on a real master process on our
hub, driven by canopen's own SdoClient from the shipped EDS: write a gain, a safety limit and a
communication object by SDO, save (0x1010 sub 1 = "save"), stop the process, start it again: the values
read back must equal the stored ones; then damage one stored value in the file and start again: the node
must refuse the file in one line naming it and run on its defaults. ``store_restore_roundtrip`` is true
only when every check holds; ``store_restore_checks`` says which held.

    python -m bench.hardware_bench --only store     (or python -m bench.hardware_store)
"""

from __future__ import annotations

import argparse
import json
import struct
import subprocess
import sys
import tempfile
import threading
from pathlib import Path
from typing import Any

import can
import canopen

from telethermo.atomic import write_json_atomic
from telethermo.bus_config import path as bus_config_path
from telethermo.nodes.launch import node_command, stop_process, wait_for
from telethermo.transport.hub import HubThread

from bench.common import current_results_dir, provenance

RESULTS_NAME = "hardware.json"
SCENE = Path(__file__).resolve().parents[1] / "sim" / "scenes" / "free_pad_identification.toml"
MASTER = 1


def _f32(x: float) -> float:
    return struct.unpack("<f", struct.pack("<f", x))[0]


class _Boots(can.Listener):
    """Counts the master's boot-up frames (0x701, state 0)."""

    def __init__(self) -> None:
        self.count = 0
        self._lock = threading.Lock()

    def on_message_received(self, msg: can.Message) -> None:
        if msg.arbitration_id == 0x700 + MASTER and bytes(msg.data) == b"\x00":
            with self._lock:
                self.count += 1


def _start(bus: str, store: Path, stderr: Path, boots: _Boots) -> subprocess.Popen:
    n = boots.count
    proc = subprocess.Popen(
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
            str(store),
        ),
        stdout=subprocess.DEVNULL,
        stderr=open(stderr, "wb"),
    )
    if not wait_for(lambda: boots.count > n or proc.poll() is not None, 60) or proc.poll() is not None:
        stop_process(proc)
        raise RuntimeError(f"the master did not boot: {stderr.read_text(errors='replace').strip()}")
    return proc


def _values(sdo) -> dict[str, Any]:
    """The objects the round trip writes: a gain, a safety limit, the heartbeat producer time (0x1017)."""
    return {"kp_A_per_C": sdo["kp_A_per_C"].raw, "T_max_C": sdo["T_max_C"].raw, "0x1017": sdo[0x1017].raw}


def store_restore(workdir: Path | None = None) -> dict[str, Any]:
    """Run the round trip (see the module docstring) in ``workdir`` (None: a temporary folder, removed after);
    return the keys for hardware.json."""
    if workdir is None:
        with tempfile.TemporaryDirectory(prefix="telethermo-store-bench-") as tmp:
            return store_restore(Path(tmp))
    work = Path(workdir)
    store, stderr = work / "node1.json", work / "master-stderr.log"
    checks: dict[str, bool] = {}
    lines: list[str] = []
    with HubThread() as hub:
        bus = f"socketcand://127.0.0.1:{hub.port}/telethermo"
        net = canopen.Network(
            can.Bus(
                interface="socketcand", host="127.0.0.1", port=hub.port, channel="telethermo", tcp_tune=True
            )
        )
        net.connect()
        boots = _Boots()
        net.notifier.add_listener(boots)
        node = canopen.RemoteNode(MASTER, str(bus_config_path("master.eds")))
        net.add_node(node)
        sdo = node.sdo
        sdo.RESPONSE_TIMEOUT = 5.0
        proc = None
        try:
            proc = _start(bus, store, stderr, boots)
            defaults = _values(sdo)
            written = {
                "kp_A_per_C": _f32(defaults["kp_A_per_C"] * 1.5 + 0.1),
                "T_max_C": _f32(40.5),
                "0x1017": 150,
            }
            sdo["kp_A_per_C"].raw, sdo["T_max_C"].raw = written["kp_A_per_C"], written["T_max_C"]
            sdo[0x1017].raw = written["0x1017"]
            sdo.download(0x1010, 1, b"save")
            checks["save_reads_capability_1"] = sdo[0x1010][1].raw == 1
            stop_process(proc)
            proc = _start(bus, store, stderr, boots)
            after = _values(sdo)
            checks["values_after_restart_equal_stored"] = after == written
            state, file = sdo["store_state"].raw, sdo["store_file"].raw
            checks["status_says_restored"] = state == 1 and file == str(store)
            stop_process(proc)
            text = store.read_text()
            kp = written["kp_A_per_C"]
            store.write_text(text.replace(json.dumps(kp), json.dumps(kp + 1.0), 1))  # one value changed
            checks["file_was_damaged"] = store.read_text() != text
            proc = _start(bus, store, stderr, boots)
            lines = [ln for ln in stderr.read_text().splitlines() if "store" in ln]
            checks["corrupted_refused_in_one_line_naming_file"] = len(lines) == 1 and str(store) in lines[0]
            now = _values(sdo)
            checks["corrupted_gives_defaults"] = now == defaults and sdo["store_state"].raw == 2
        finally:
            stop_process(proc)
            net.disconnect()
    return {
        "store_restore_roundtrip": all(checks.values()) and len(checks) == 6,
        "store_restore_checks": dict(checks, refused_line=lines[0] if lines else None),
    }


def merge_results(update: dict[str, Any], *, results_dir: Path | None = None, part: str) -> Path:
    """``update`` into hardware.json, keeping every other key (and each part's own provenance)."""
    path = Path(results_dir if results_dir is not None else current_results_dir()) / RESULTS_NAME
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        if not isinstance(data, dict):
            data = {}
    except (FileNotFoundError, json.JSONDecodeError):
        data = {}
    data.update(update)
    data.setdefault("provenance_by_part", {})[part] = provenance()
    return write_json_atomic(path, data)


PARTS = {"store": store_restore}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.hardware_store", description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", choices=list(PARTS), action="append", help="run only this part (repeatable)")
    args = ap.parse_args(argv)
    ok = True
    for name in args.only or list(PARTS):
        result = PARTS[name]()
        path = merge_results(result, part=name)
        print(json.dumps(result, indent=2))
        print(f"wrote {path}")
        ok = ok and all(v for k, v in result.items() if isinstance(v, bool))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
