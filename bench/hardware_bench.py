"""Hardware path (issue 24): how fast a simulated CiA 401 I/O module cuts the drive by itself when the
controller is killed with SIGKILL. Writes ``bench/results/hardware.json`` (keys it owns are replaced,
others' kept):

- ``io_module_cut_ms``: the worst of ``runs`` SIGKILLs (≥ 10), ``io_module_cut_ms_median``: their median.
  One run: a stand-in controller (``bench/standin_controller.py``, its own process: SYNC, RPDO of 2 A,
  heartbeat every 50 ms) drives ``telethermo-iomodule`` over the hub until the module applies 2 A; the bench
  SIGKILLs it and reads the module's output actual (0x2101) by SDO as fast as the SDO round trip allows
  until it reads 0 counts (0 A). The time from the kill to that SDO answer is an upper bound of the cut
  (it includes one SDO round trip). Module commissioned as telethermo.iomodule.commission does: consumer
  heartbeat 150 ms on the controller, 0x6443 = 1, 0x6444 = 0, 0x1029 = 0.
- ``io_module_emcy_ms_*``: kill to the module's EMCY 0x8130 (sent just before it applies the substitute);
  ``io_module_silence_ms_min``: the shortest time from the controller's last heartbeat to that EMCY, by the
  hub's time stamps (≥ the 150 ms consumer time: the module never cuts early).

- ``rig_check_faults_detected`` (``--only rigcheck``): bench.rig_check_bench, every injected wiring fault
  named by ``telethermo rig check`` and none on a correct rig.
- the I/O rig's figures (``--only io``): bench.io_rig_bench (the §5.3 headline through in-process simulated
  modules against the direct rig; the bus load of the four-node session at 100 Hz over the hub).

    python -m bench.hardware_bench [--runs N] [--only cut|io|rigcheck|store]
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import statistics
import subprocess
import sys
import time
from pathlib import Path

import can
import canopen

from bench import hardware_store, io_rig_bench, rig_check_bench
from bench.common import current_results_dir, print_table, write_results
from telethermo.bus_config import path
from telethermo.cia301 import EMCY_HEARTBEAT
from telethermo.iomodule.scaling import COUNTS_PER_V
from telethermo.nodes.children import readline_within, stop_process
from telethermo.transport.hub import HubThread

MODULE_ID, CONTROLLER_ID, CONSUMER_MS = 3, 1, 150
TWO_AMPS = round(2.0 * COUNTS_PER_V)
STANDIN = Path(__file__).resolve().with_name("standin_controller.py")
OWN_KEYS = (
    "io_module_cut_ms",
    "io_module_cut_ms_median",
    "io_module_cut_runs",
    "io_module_emcy_ms_max",
    "io_module_emcy_ms_median",
    "io_module_silence_ms_min",
    "io_module_consumer_ms",
)


def _wait(fn, timeout_s: float, what: str):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        got = fn()
        if got:
            return got
        time.sleep(0.002)
    raise RuntimeError(f"timed out waiting for {what}")


def measure(runs: int) -> dict:
    """``runs`` SIGKILLs of the stand-in controller against one module process; the figures."""
    with HubThread() as hub:
        exe = Path(sys.executable).with_name("telethermo-iomodule")
        module = subprocess.Popen(
            [str(exe), "--node-id", str(MODULE_ID), "--bus", f"socketcand://127.0.0.1:{hub.port}/vcan0"],
            stderr=subprocess.DEVNULL,
        )
        net = canopen.Network(
            can.Bus(interface="socketcand", host="127.0.0.1", port=hub.port, channel="vcan0", tcp_tune=True)
        )
        net.connect()
        emcys, hbs = [], []
        net.subscribe(0x80 + MODULE_ID, lambda c, d, ts: emcys.append((time.monotonic(), bytes(d), ts)))
        net.subscribe(0x700 + CONTROLLER_ID, lambda c, d, ts: hbs.append(ts))
        node = net.add_node(MODULE_ID, str(path("io_module.eds")))
        node.sdo.RESPONSE_TIMEOUT = 1.0
        try:

            def up():
                try:
                    return node.sdo[0x1000].raw
                except (canopen.SdoCommunicationError, canopen.SdoAbortedError):
                    return None

            _wait(up, 60, "the module")
            node.sdo[0x2100].raw = 10
            node.sdo[0x1016][1].raw = (CONTROLLER_ID << 16) | CONSUMER_MS
            node.sdo[0x6443][1].raw, node.sdo[0x6444][1].raw, node.sdo[0x1029][1].raw = 1, 0, 0
            cut, emcy, silence = [], [], []
            for _ in range(runs):
                emcys.clear()
                standin = subprocess.Popen(
                    [
                        sys.executable,
                        str(STANDIN),
                        str(hub.port),
                        str(MODULE_ID),
                        str(CONTROLLER_ID),
                        str(TWO_AMPS),
                    ],
                    stdout=subprocess.PIPE,
                    text=True,
                )
                if not readline_within(standin, 30.0):
                    stop_process(standin)
                    raise RuntimeError("the stand-in controller printed no ready line within 30 s")
                _wait(lambda: node.sdo[0x2101].raw == TWO_AMPS, 20, "2 A applied")
                time.sleep(0.2)  # a few heartbeats in: the kill lands anywhere in the 50 ms heartbeat period
                t_kill = time.monotonic()
                os.kill(standin.pid, signal.SIGKILL)
                t_zero = _wait(lambda: node.sdo[0x2101].raw == 0 and time.monotonic(), 10, "0 A")
                standin.wait()
                loss = EMCY_HEARTBEAT.to_bytes(2, "little")
                t_emcy, data, ts = _wait(lambda: [e for e in emcys if e[1][:2] == loss], 5, "EMCY 0x8130")[0]
                cut.append((t_zero - t_kill) * 1e3)
                emcy.append((t_emcy - t_kill) * 1e3)
                silence.append((ts - max(h for h in hbs if h <= ts)) * 1e3)
        finally:
            net.disconnect()
            module.send_signal(signal.SIGTERM)
            module.wait(timeout=20)
    return {
        "io_module_cut_ms": max(cut),
        "io_module_cut_ms_median": statistics.median(cut),
        "io_module_cut_runs": [round(c, 2) for c in cut],
        "io_module_emcy_ms_max": max(emcy),
        "io_module_emcy_ms_median": statistics.median(emcy),
        "io_module_silence_ms_min": min(silence),
        "io_module_consumer_ms": CONSUMER_MS,
    }


def run(
    quick: bool = False, runs: int | None = None, parts: tuple[str, ...] = ("cut", "io", "rigcheck")
) -> dict:
    """The figures of ``parts`` ("cut": the SIGKILL cut; "io": the I/O rig, bench.io_rig_bench), merged into
    hardware.json (every other key kept: other benches write theirs there too)."""
    got: dict = {}
    if "cut" in parts:
        got.update(measure(runs or (10 if quick else 20)))
        print_table(["figure", "ms"], [[k, got[k]] for k in OWN_KEYS if k not in ("io_module_cut_runs",)])
    if "io" in parts:
        io = {
            **io_rig_bench.headline(duration_s=5.0 if quick else None),
            **io_rig_bench.bus_load_4_nodes(cycles=300 if quick else 6000),  # 60 s at 100 Hz
        }
        print_table(["figure", "value"], [[k, v] for k, v in io.items() if not isinstance(v, dict)])
        got.update(io)
    if "rigcheck" in parts:
        rc = rig_check_bench.run()
        print_table(["fault", "named"], [[k, v] for k, v in rc["rig_check_faults_detected"].items()])
        got.update(rc)
    target = current_results_dir() / "hardware.json"
    old = json.loads(target.read_text()) if target.exists() else {}  # read just before writing: merge
    old.pop("provenance", None)
    write_results("hardware", {**old, **got})
    return got


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=20, help="SIGKILLs (default 20, at least 10)")
    ap.add_argument(
        "--only",
        choices=["cut", "io", "rigcheck", "store"],
        action="append",
        help="run only this part (repeatable): cut = the SIGKILL cut, io = the I/O rig figures, "
        "rigcheck = rig check names every injected wiring fault (bench/rig_check_bench.py), "
        "store = store/restore (bench/hardware_store.py)",
    )
    a = ap.parse_args()
    parts = tuple(a.only or ("cut", "io", "rigcheck", "store"))
    if {"cut", "io", "rigcheck"} & set(parts):
        run(runs=max(10, a.runs), parts=tuple(p for p in parts if p in ("cut", "io", "rigcheck")))
    if "store" in parts:
        sys.exit(hardware_store.main(["--only", "store"]))
