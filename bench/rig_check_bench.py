"""``rig_check_faults_detected`` for bench/results/hardware.json (issue 24 item 3): each wiring fault injected
into a real ``telethermo-iomodule`` process on the hub (``--fault``), ``telethermo rig check`` (its own
process) run against it; true when the check's one line names that fault (its ``[key]``), and
``correct_rig`` true when a module without faults passes with no fault named.

    python -m bench.hardware_bench --only rigcheck
"""

from __future__ import annotations

import logging
import signal
import subprocess
import sys
import time
from pathlib import Path

import can
import canopen

from telethermo.bus_config import path
from telethermo.transport.hub import HubThread

MODULE_ID = 3
BIN = Path(sys.executable).parent
RIG_TOML = path("rig_io_sim.toml")
#: fault name -> (the module's --fault options, the key rig check must name)
FAULTS = {
    "sign_T_sensor": (["sign:1"], "sign:T_sensor_C"),
    "sign_Q": (["sign:2"], "sign:Q_W"),
    "sign_T_sink": (["sign:3"], "sign:T_sink_C"),
    "sign_current_monitor": (["sign:6"], "sign:current_A"),
    "sign_drive": (["sign:out"], "sign:drive"),
    "scale_x10_current_monitor": (["scale:6:10"], "scale:current_A"),
    "scale_x10_Q": (["scale:2:10"], "scale:Q_W"),
    "open_thermocouple": (["open:1"], "open:T_sensor_C"),
    "short_thermocouple": (["short:1"], "short:T_sensor_C"),
    "swap_T_sensor_T_sink": (["swap:1:3"], "swap:T_sensor_C:T_sink_C"),
    "sampling_400ms": (["sampling:400"], "sampling:io"),
}


def named_key(faults: list[str]) -> str | None:
    """Run ``rig check`` against a module with ``faults``; the key it named (None: it passed)."""
    logging.getLogger("canopen.sdo.client").setLevel(logging.CRITICAL)  # the wait for the module's boot
    with HubThread() as hub:
        bus_arg = f"socketcand://127.0.0.1:{hub.port}/vcan0"
        cmd = [str(BIN / "telethermo-iomodule"), "--node-id", str(MODULE_ID), "--bus", bus_arg]
        proc = subprocess.Popen(cmd + [a for f in faults for a in ("--fault", f)], stderr=subprocess.DEVNULL)
        net = canopen.Network(
            can.Bus(interface="socketcand", host="127.0.0.1", port=hub.port, channel="vcan0", tcp_tune=True)
        )
        net.connect()
        node = net.add_node(MODULE_ID, str(path("io_module.eds")))
        try:
            deadline = time.monotonic() + 60
            while True:
                try:
                    node.sdo[0x1000].raw
                    break
                except (canopen.SdoCommunicationError, canopen.SdoAbortedError):
                    if time.monotonic() > deadline or proc.poll() is not None:
                        raise RuntimeError("the module did not come up") from None
            res = subprocess.run(
                [
                    str(BIN / "telethermo"),
                    "rig",
                    "check",
                    "1",
                    "-q",
                    "--rig-config",
                    str(RIG_TOML),
                    "--bus",
                    bus_arg,
                ],
                capture_output=True,
                text=True,
                timeout=300,
            )
        finally:
            net.disconnect()
            proc.send_signal(signal.SIGTERM)
            proc.wait(timeout=20)
    if res.returncode == 0:
        return None
    line = res.stderr.strip()
    return line.split("[", 1)[1].split("]", 1)[0] if res.returncode == 1 and "[" in line else f"?{line}"


def run() -> dict:
    got: dict[str, bool] = {"correct_rig": named_key([]) is None}
    keys: dict[str, str | None] = {}
    for name, (options, key) in FAULTS.items():
        keys[name] = named_key(options)
        got[name] = keys[name] == key
    return {"rig_check_faults_detected": got, "rig_check_named_keys": keys}
