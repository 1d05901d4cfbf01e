"""The simulated I/O module (``telethermo-iomodule``) as its own process over our hub, driven by canopen's
RemoteNode from bus_config/io_module.eds as a third-party client, and by a stand-in controller (raw
python-can frames, its own process) that is killed with SIGKILL (issue 24 items 2 and 4)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import canopen
import pytest

from telethermo.cia301 import EMCY_HEARTBEAT, EMCY_INPUT_SENTINEL
from telethermo.iomodule.scaling import COUNTS_PER_V, OVERLOAD_POS
from tests.iomodule.helpers import CONTROLLER_ID, MODULE_ID

pytestmark = pytest.mark.slow  # starts processes

STANDIN = Path(__file__).resolve().parents[2] / "bench" / "standin_controller.py"
TWO_AMPS = round(2.0 * COUNTS_PER_V)  # 1 A/V amplifier: 2 A is 6554 counts
#: the module's heartbeat consumer time for its controller, ms: the packaged RIG.toml's is 150 ms, against
#: the stand-in's heartbeats every 50 ms; a stand-in, hub or module late by 100 ms on a loaded machine then
#: cut the drive before the test's SIGKILL. 1 s: the same watch, the same cut, the same EMCY
WATCH_MS = 1000


def _commission(node, *, error_mode: int) -> None:
    """What the controller's commissioning writes (item 1): sampling every SYNC, watch node 1 (for
    ``WATCH_MS``), the output's error mode and substitute 0 A, PRE-OPERATIONAL on a communication error."""
    node.sdo[0x2100].raw = 10
    node.sdo[0x1016][1].raw = (CONTROLLER_ID << 16) | WATCH_MS
    node.sdo[0x6443][1].raw = error_mode
    node.sdo[0x6444][1].raw = 0
    node.sdo[0x1029][1].raw = 0


def test_the_eds_defaults_are_the_real_modules_traps(rig):
    _, bus, _ = rig
    node = bus.node
    assert node.sdo[0x2100].raw == 400  # 2.5 Hz sampling
    assert node.sdo[0x6443][1].raw == 0  # hold the last value on error
    assert node.sdo[0x1016][1].raw == 0  # nobody watched
    bus.wait(lambda: bus.module_state() == 0x7F)  # booted into PRE-OPERATIONAL (its heartbeat says so)
    with pytest.raises(canopen.SdoAbortedError) as exc:
        node.sdo[0x6401][1].raw = 5  # inputs are read-only
    assert exc.value.code == 0x06010002
    with pytest.raises(canopen.SdoAbortedError) as exc:
        node.sdo[0x2100].raw = 0  # below the sampling period's range
    assert exc.value.code in (0x06090032, 0x06090030)


def test_inputs_on_sync_by_the_eds_tpdos_hold_between_conversions_and_report_a_sentinel(rig):
    _, bus, _ = rig
    node, net = bus.node, bus.network
    node.tpdo.read(from_od=True)
    node.nmt.send_command(0x01)
    bus.wait(lambda: bus.module_state() == 0x05)
    frames: list[tuple[int, ...]] = []
    node.tpdo[1].add_callback(lambda pdo: frames.append(tuple(v.raw for v in pdo)))

    def sync_until(n, timeout_s=10.0):
        count = 0
        while len(frames) < n:
            count += 1
            net.sync.transmit(count % 240 + 1)
            bus.wait(lambda: len(frames) >= min(n, count) or None, timeout_s=timeout_s)

    sync_until(45)  # 400 ms default: one conversion per 40 SYNCs of 10 ms
    firsts = [f[0] for f in frames]
    assert abs(firsts[0] - 25.0 * 0.1 * COUNTS_PER_V) <= 50  # pads in air at 25 °C, 100 mV/°C
    changes = [k for k in range(1, len(frames)) if frames[k] != frames[k - 1]]
    assert changes == [40]  # values change only when the ADC converts (noisy inputs)
    node.sdo[0x2110].raw = 0b1  # input 1 (the thermocouple) open
    frames.clear()
    sync_until(41)
    assert frames[-1][0] == OVERLOAD_POS
    emcy = bus.wait(lambda: [e for e in bus.emcys if e[1] == EMCY_INPUT_SENTINEL])
    assert emcy[0][2][:3] == bytes([1]) + OVERLOAD_POS.to_bytes(2, "little")
    node.sdo[0x2100].raw = 10
    node.sdo[0x2110].raw = 0
    frames.clear()
    sync_until(2)
    assert frames[-1][0] != OVERLOAD_POS
    bus.wait(lambda: [e for e in bus.emcys if e[1] == 0x0000])  # the error reset EMCY


def _kill_controller(rig, *, error_mode: int) -> dict:
    """Commission, run the stand-in controller until the module applies its RPDO, SIGKILL it; what
    followed."""
    hub, bus, _ = rig
    node = bus.node
    _commission(node, error_mode=error_mode)
    standin = subprocess.Popen(
        [sys.executable, str(STANDIN), str(hub.port), str(MODULE_ID), str(CONTROLLER_ID), str(TWO_AMPS)],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert standin.stdout.readline().strip() == "running"
        # the RPDO sets the output at once (0x2101); the drive monitor (0x6401:6) shows it from the next
        # SYNC's conversion, which a loaded machine may deliver after the test's next SDO read: wait for both
        bus.wait(
            lambda: (
                node.sdo[0x2101].raw == TWO_AMPS
                and node.sdo[0x6401][6].raw == TWO_AMPS
                and bus.module_state() == 0x05
            ),
            timeout_s=20,
        )
        before = {
            "actual": node.sdo[0x2101].raw,
            "error": node.sdo[0x2102].raw,
            "drive": node.sdo[0x6401][6].raw,
        }
        t_kill = time.monotonic()
        os.kill(standin.pid, signal.SIGKILL)
    finally:
        standin.kill()
        standin.wait()
    settled = (
        (lambda: node.sdo[0x2102].raw == 1 and time.monotonic())
        if error_mode == 0
        else (lambda: node.sdo[0x2101].raw == 0 and time.monotonic())
    )
    t_cut = bus.wait(settled, every_s=0.0)
    loss = bus.wait(lambda: [e for e in bus.emcys if e[1] == EMCY_HEARTBEAT])[0]
    bus.wait(lambda: bus.module_state() == 0x7F)  # 0x1029:1 = 0: PRE-OPERATIONAL
    for k in range(3):  # SYNCs from here advance the plant and convert
        bus.network.sync.transmit(k + 1)
    after = {"actual": node.sdo[0x2101].raw, "error": node.sdo[0x2102].raw, "drive": node.sdo[0x6401][6].raw}
    last_hb = max(ts for _, n, _, ts in bus.heartbeats if n == CONTROLLER_ID)
    return {
        "before": before,
        "after": after,
        "cut_ms": (t_cut - t_kill) * 1e3,
        "emcy": loss,
        "emcy_ms": (loss[0] - t_kill) * 1e3,
        "silence_ms": (loss[3] - last_hb) * 1e3,
    }


def test_sigkill_of_the_controller_cuts_the_drive_to_the_substitute_by_the_module_itself(rig):
    got = _kill_controller(rig, error_mode=1)
    assert got["before"] == {"actual": TWO_AMPS, "error": 0, "drive": TWO_AMPS}  # 2 A commanded and flowing
    assert got["after"] == {"actual": 0, "error": 1, "drive": 0}  # 0 A, measured at the drive
    assert got["emcy"][2][:1] == bytes([CONTROLLER_ID])  # 0x8130 names the lost node
    # the module waited for its consumer time after the controller's last heartbeat (the hub's time stamps)
    assert got["silence_ms"] >= WATCH_MS
    print(
        f"cut after SIGKILL: {got['cut_ms']:.1f} ms (SDO-confirmed), "
        f"EMCY 0x8130 after {got['emcy_ms']:.1f} ms, "
        f"{got['silence_ms']:.1f} ms after the last heartbeat"
    )


def test_with_the_example_eds_error_mode_the_drive_keeps_pumping(rig):
    got = _kill_controller(rig, error_mode=0)
    # the trap: 2 A after the loss
    assert got["after"] == {"actual": TWO_AMPS, "error": 1, "drive": TWO_AMPS}
