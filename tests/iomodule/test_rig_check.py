"""``telethermo rig check`` (issue 24 item 3) against real ``telethermo-iomodule`` processes on the hub, one
per injected wiring fault (``--fault``): the CLI, its own process, names each fault in one line (exit 1),
and a correct rig passes naming none (exit 0); the module's state afterwards is read by the test's own
canopen RemoteNode (from the module's EDS): the check leaves it PRE-OPERATIONAL with the drive at 0 A."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

import pytest

from telethermo.bus_config import path as bus_config_path
from telethermo.nodes.launch import node_command, stop_process
from telethermo.transport.hub import HubThread
from tests.iomodule.helpers import MODULE_ID, Bus, up

SIM_TOML = bus_config_path("rig_io_sim.toml")
SCENE = Path(__file__).resolve().parents[2] / "sim" / "scenes" / "free_pad_identification.toml"
BIN = Path(sys.executable).parent

#: fault name (as in hardware.json) -> (the module's --fault options, the key rig check must name)
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


def run_check(
    faults: list[str], rig_config: Path = SIM_TOML, store: Path | None = None
) -> tuple[subprocess.CompletedProcess, Bus]:
    """A hub, a module process with ``faults``, ``telethermo rig check`` against it; the CLI's result and the
    module's state read by the test's own client afterwards (returned closed). ``store``: a controller node
    (``telethermo-master --no-sync``, idle) with that store file is up too, and the check runs ``--store``."""
    with HubThread() as hub:
        bus_arg = f"socketcand://127.0.0.1:{hub.port}/vcan0"
        cmd = [str(BIN / "telethermo-iomodule"), "--node-id", str(MODULE_ID), "--bus", bus_arg]
        proc = subprocess.Popen(
            cmd + [a for f in faults for a in ("--fault", f)],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        bus = Bus(hub.port)
        master = None
        try:
            bus.wait(lambda: up(bus) or proc.poll() is not None, timeout_s=60, every_s=0.1)
            assert proc.poll() is None, proc.communicate()[1]
            extra = []
            if store is not None:
                master = subprocess.Popen(
                    node_command(
                        "master",
                        "--bus",
                        bus_arg,
                        "--scene",
                        str(SCENE),
                        "--no-sync",
                        "--mode",
                        "idle",
                        "--cycles",
                        "0",
                        "--store",
                        str(store),
                        "--log",
                        str(store.with_suffix(".log")),
                    ),
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                )
                bus.wait(lambda: any(n == 1 for _, n, _, _ in bus.heartbeats), timeout_s=60, every_s=0.1)
                extra = ["--store"]
            res = subprocess.run(
                [
                    str(BIN / "telethermo"),
                    "rig",
                    "check",
                    "1",
                    *extra,
                    "--rig-config",
                    str(rig_config),
                    "--bus",
                    bus_arg,
                ],
                capture_output=True,
                text=True,
                timeout=300,
            )
            # the check's last NMT (PRE-OPERATIONAL) may still be on its way when the CLI has exited: the
            # state is the module's heartbeat once it says PRE-OPERATIONAL, or its last one after 10 s
            try:
                state = bus.wait(lambda: bus.module_state() == 0x7F and 0x7F, timeout_s=10, every_s=0.05)
            except AssertionError:
                state = bus.module_state()
            bus.after = (bus.node.sdo[0x2101].raw, state)
        finally:
            bus.close()
            stop_process(master)
            proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(timeout=20)
            finally:
                if proc.poll() is None:
                    proc.kill()
    return res, bus


def named(res: subprocess.CompletedProcess) -> str | None:
    """The fault key the check named (``[key]`` in its one line), None if it passed."""
    if res.returncode == 0:
        return None
    line = res.stderr.strip()
    assert res.returncode == 1 and "\n" not in line, res.stderr
    return line.split("[", 1)[1].split("]", 1)[0]


@pytest.mark.slow
def test_correct_rig_passes_naming_nothing():
    res, bus = run_check([])
    assert res.returncode == 0, res.stderr
    assert "passed" in res.stdout and res.stderr == ""
    assert bus.after == (0, 0x7F)  # drive at 0 A, module PRE-OPERATIONAL again


@pytest.mark.slow
@pytest.mark.parametrize("fault", sorted(FAULTS))
def test_each_injected_fault_is_named(fault):
    options, key = FAULTS[fault]
    res, bus = run_check(options)
    assert named(res) == key, res.stderr
    assert "telethermo rig: check failed" in res.stderr
    assert bus.after == (0, 0x7F)


@pytest.mark.slow  # runs the CLI as a process
def test_bad_rig_config_is_one_line_exit_2(tmp_path):
    bad = tmp_path / "RIG.toml"
    bad.write_text(SIM_TOML.read_text(encoding="utf-8").replace("limit_A = 3.0", "limit_A = -1"))
    res = subprocess.run(
        [str(BIN / "telethermo"), "rig", "check", "--rig-config", str(bad), "--bus", "virtual:nobody"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert res.returncode == 2 and res.stderr.count("\n") == 1, res.stderr
    assert str(bad) in res.stderr and "drive.limit_A" in res.stderr


@pytest.mark.slow
def test_gain_x10_in_the_rig_file_is_named_at_rest(tmp_path):
    cfg = tmp_path / "RIG.toml"
    text = SIM_TOML.read_text(encoding="utf-8")
    cfg.write_text(text.replace("gain = 10.0                  # °C per V", "gain = 100.0"))
    res, _ = run_check([], rig_config=cfg)
    assert named(res) == "scale:T_sensor_C", res.stderr


@pytest.mark.slow
def test_store_saves_on_the_node_only_after_every_step_passed(tmp_path):
    store = tmp_path / "node1.json"
    res, _ = run_check(["sign:2"], store=store)
    assert named(res) == "sign:Q_W" and not store.exists()  # a fault: nothing written to the node
    res, _ = run_check([], store=store)
    assert res.returncode == 0, res.stderr
    assert "master (node 1): all parameters saved" in res.stdout and store.is_file()
