"""The simulated I/O module (``telethermo-iomodule``) as its own process over our hub, driven by canopen's
RemoteNode from bus_config/io_module.eds as a third-party client, and by a stand-in controller (raw
python-can frames, its own process) that is killed with SIGKILL (issue 24 items 2 and 4)."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import can
import canopen
import pytest

from telethermo.bus_config import path
from telethermo.cia301 import EMCY_HEARTBEAT, EMCY_INPUT_SENTINEL
from telethermo.iomodule.scaling import COUNTS_PER_V, OVERLOAD_POS
from telethermo.transport.hub import HubThread

pytestmark = pytest.mark.slow  # starts processes

MODULE_ID, CONTROLLER_ID = 3, 1
STANDIN = Path(__file__).resolve().parents[2] / "bench" / "standin_controller.py"
EDS = str(path("io_module.eds"))
TWO_AMPS = round(2.0 * COUNTS_PER_V)   # 1 A/V amplifier: 2 A is 6554 counts


class Bus:
    """The test's own view of the bus: a canopen network with the module as a RemoteNode, and the EMCY and
    heartbeat frames of every node with their arrival time (time.monotonic, the clock the test kills by) and
    the hub's time stamp of the frame (time.time when the hub took it from its sender: the wire's clock)."""

    def __init__(self, port: int):
        self.network = canopen.Network(can.Bus(interface="socketcand", host="127.0.0.1", port=port,
                                               channel="vcan0", tcp_tune=True))
        self.network.connect()
        self.node = self.network.add_node(MODULE_ID, EDS)
        self.node.sdo.RESPONSE_TIMEOUT = 1.0
        self.emcys: list[tuple[float, int, bytes, float]] = []
        self.heartbeats: list[tuple[float, int, int, float]] = []
        self.network.subscribe(0x80 + MODULE_ID, self._on_emcy)
        for node_id in (MODULE_ID, CONTROLLER_ID):
            self.network.subscribe(0x700 + node_id, self._on_heartbeat)

    def _on_emcy(self, cob, data, ts):
        self.emcys.append((time.monotonic(), int.from_bytes(data[:2], "little"), bytes(data[3:]), ts))

    def _on_heartbeat(self, cob, data, ts):
        self.heartbeats.append((time.monotonic(), cob - 0x700, data[0], ts))

    def wait(self, what, timeout_s: float = 10.0, every_s: float = 0.005):
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            got = what()
            if got:
                return got
            time.sleep(every_s)
        raise AssertionError(f"timed out waiting for {what}")

    def module_state(self) -> int | None:
        states = [s for _, n, s, _ in self.heartbeats if n == MODULE_ID]
        return states[-1] if states else None

    def close(self):
        self.network.disconnect()


def _up(bus: Bus) -> bool:
    try:
        return bus.node.sdo[0x1000].raw == 0x000C0191
    except (canopen.SdoCommunicationError, canopen.SdoAbortedError):
        return False


@pytest.fixture
def rig():
    """A hub, a running ``telethermo-iomodule`` on it and the test's RemoteNode of it, answering SDO."""
    with HubThread() as hub:
        exe = Path(sys.executable).with_name("telethermo-iomodule")
        proc = subprocess.Popen([str(exe), "--node-id", str(MODULE_ID), "--scene", "pads_in_air",
                                 "--bus", f"socketcand://127.0.0.1:{hub.port}/vcan0"],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        bus = Bus(hub.port)
        try:
            bus.wait(lambda: _up(bus) or proc.poll() is not None, timeout_s=60, every_s=0.1)
            assert proc.poll() is None, proc.communicate()[1]
            yield hub, bus, proc
        finally:
            bus.close()
            proc.send_signal(signal.SIGTERM)
            try:
                assert proc.wait(timeout=20) == 0, proc.communicate()[1]
            finally:
                if proc.poll() is None:
                    proc.kill()


def _commission(node, *, error_mode: int) -> None:
    """What the controller's commissioning writes (item 1): sampling every SYNC, watch node 1 for 150 ms,
    the output's error mode and substitute 0 A, PRE-OPERATIONAL on a communication error."""
    node.sdo[0x2100].raw = 10
    node.sdo[0x1016][1].raw = (CONTROLLER_ID << 16) | 150
    node.sdo[0x6443][1].raw = error_mode
    node.sdo[0x6444][1].raw = 0
    node.sdo[0x1029][1].raw = 0


def test_the_eds_defaults_are_the_real_modules_traps(rig):
    _, bus, _ = rig
    node = bus.node
    assert node.sdo[0x2100].raw == 400             # 2.5 Hz sampling
    assert node.sdo[0x6443][1].raw == 0            # hold the last value on error
    assert node.sdo[0x1016][1].raw == 0            # nobody watched
    bus.wait(lambda: bus.module_state() == 0x7F)   # booted into PRE-OPERATIONAL (its heartbeat says so)
    with pytest.raises(canopen.SdoAbortedError) as exc:
        node.sdo[0x6401][1].raw = 5                # inputs are read-only
    assert exc.value.code == 0x06010002
    with pytest.raises(canopen.SdoAbortedError) as exc:
        node.sdo[0x2100].raw = 0                   # below the sampling period's range
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

    sync_until(45)                                 # 400 ms default: one conversion per 40 SYNCs of 10 ms
    firsts = [f[0] for f in frames]
    assert abs(firsts[0] - 25.0 * 0.1 * COUNTS_PER_V) <= 50   # pads in air at 25 °C, 100 mV/°C
    changes = [k for k in range(1, len(frames)) if frames[k] != frames[k - 1]]
    assert changes == [40]                         # values change only when the ADC converts (noisy inputs)
    node.sdo[0x2110].raw = 0b1                     # input 1 (the thermocouple) open
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
    bus.wait(lambda: [e for e in bus.emcys if e[1] == 0x0000])   # the error reset EMCY


def _kill_controller(rig, *, error_mode: int) -> dict:
    """Commission, run the stand-in controller until the module applies its RPDO, SIGKILL it; what followed."""
    hub, bus, _ = rig
    node = bus.node
    _commission(node, error_mode=error_mode)
    standin = subprocess.Popen([sys.executable, str(STANDIN), str(hub.port), str(MODULE_ID),
                                str(CONTROLLER_ID), str(TWO_AMPS)], stdout=subprocess.PIPE, text=True)
    try:
        assert standin.stdout.readline().strip() == "running"
        bus.wait(lambda: node.sdo[0x2101].raw == TWO_AMPS and bus.module_state() == 0x05, timeout_s=20)
        before = {"actual": node.sdo[0x2101].raw, "error": node.sdo[0x2102].raw,
                  "drive": node.sdo[0x6401][6].raw}
        t_kill = time.monotonic()
        os.kill(standin.pid, signal.SIGKILL)
    finally:
        standin.kill()
        standin.wait()
    settled = (lambda: node.sdo[0x2102].raw == 1 and time.monotonic()) if error_mode == 0 else \
        (lambda: node.sdo[0x2101].raw == 0 and time.monotonic())
    t_cut = bus.wait(settled, every_s=0.0)
    loss = bus.wait(lambda: [e for e in bus.emcys if e[1] == EMCY_HEARTBEAT])[0]
    bus.wait(lambda: bus.module_state() == 0x7F)   # 0x1029:1 = 0: PRE-OPERATIONAL
    for k in range(3):                            # SYNCs from here advance the plant and convert
        bus.network.sync.transmit(k + 1)
    after = {"actual": node.sdo[0x2101].raw, "error": node.sdo[0x2102].raw, "drive": node.sdo[0x6401][6].raw}
    last_hb = max(ts for _, n, _, ts in bus.heartbeats if n == CONTROLLER_ID)
    return {"before": before, "after": after, "cut_ms": (t_cut - t_kill) * 1e3, "emcy": loss,
            "emcy_ms": (loss[0] - t_kill) * 1e3, "silence_ms": (loss[3] - last_hb) * 1e3}


def test_sigkill_of_the_controller_cuts_the_drive_to_the_substitute_by_the_module_itself(rig):
    got = _kill_controller(rig, error_mode=1)
    assert got["before"] == {"actual": TWO_AMPS, "error": 0, "drive": TWO_AMPS}   # 2 A commanded and flowing
    assert got["after"] == {"actual": 0, "error": 1, "drive": 0}                  # 0 A, measured at the drive
    assert got["emcy"][2][:1] == bytes([CONTROLLER_ID])                          # 0x8130 names the lost node
    # the module waited for its consumer time after the controller's last heartbeat (the hub's time stamps)
    assert got["silence_ms"] >= 150
    print(f"cut after SIGKILL: {got['cut_ms']:.1f} ms (SDO-confirmed), EMCY 0x8130 after {got['emcy_ms']:.1f} ms, "
          f"{got['silence_ms']:.1f} ms after the last heartbeat")


def test_with_the_example_eds_error_mode_the_drive_keeps_pumping(rig):
    got = _kill_controller(rig, error_mode=0)
    assert got["after"] == {"actual": TWO_AMPS, "error": 1, "drive": TWO_AMPS}   # the trap: 2 A after the loss
