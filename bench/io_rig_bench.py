"""The rig behind CANopen I/O modules (issue 24 item 2): what the I/O path costs the operator, and the bus
load of the four nodes at 100 Hz. Called by ``python -m bench.hardware_bench --only io``.

- ``io_rig_headline_C``, ``io_rig_headline_ratio_to_direct_rig``: the §5.3 scene (probe touches aluminium,
  steel, wood) run by the offline runner's telepresence loop (the controllers' one step function, REAL32
  exchange as the nodes do) twice: with the simulated rigs read and driven directly, and with each rig
  behind its simulated I/O module, **in-process**: the module is the real
  :class:`telethermo.iomodule.module.IoModule` (our device layer, its own canopen network) and the
  controller's side is the real I/O rig driver (:class:`telethermo.iomodule.iorig.IoRig`, commissioned from
  ``bus_config/rig_io_sim*.toml``), the two on one python-can virtual channel per side: every cycle is a
  SYNC frame, the module's two TPDOs (16-bit ADC codes) and the driver's RPDO (16-bit DAC code). The
  controllers' own frames (peer PDOs) are not on that channel: the runner hands the peer values over in
  lockstep, as for the direct rig.
- ``io_rig_bus_load_100hz``, ``io_rig_late_cycles_100hz_60s`` (``_100hz`` for a session shorter than 60 s):
  a real-time session of four processes over the
  hub (two ``telethermo-iomodule`` with the scene's rig sides, ``telethermo-master``/``-slave --rig io``),
  every frame counted by a listener on the hub; the load is the frames' bits with stuffing at the network's
  bit rate (telethermo.transport.bus.bus_load)."""

from __future__ import annotations

import collections
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import can
import canopen

from telethermo.bus_config import path as bus_config_path
from telethermo.device import DeviceSettings
from telethermo.iomodule.iorig import IoRig
from telethermo.iomodule.module import IoModule
from telethermo.iomodule.rigconfig import load_rig_config
from telethermo.offline.runner import run_offline_session
from telethermo.recording.result import RESULT_PREFIX, RunResult
from telethermo.transport.bus import DEFAULT_BITRATE, bus_load
from telethermo.transport.hub import HubThread

SCENE = "probe_touches_al_steel_wood"
TOML = {"master": "rig_io_sim.toml", "slave": "rig_io_sim_slave.toml"}
CONTROLLER = {"master": 1, "slave": 2}


class InProcessIoSide:
    """One side's simulated rig behind its simulated I/O module, in-process, as the offline runner drives a
    rig: :meth:`advance` is the controller's SYNC, :meth:`read` the driver's read of the module's TPDOs after
    it (cycle 0, before any SYNC: the module converts once and the driver reads the inputs by SDO)."""

    def __init__(self, sim_rig, role: str, channel: str):
        self.sim = sim_rig
        self.period_s = sim_rig.period_s
        cfg = load_rig_config(bus_config_path(TOML[role]))
        node_id = cfg.modules["io"].node_id
        self.module_net = canopen.Network(can.Bus(interface="virtual", channel=channel))
        self.module_net.connect()
        self.module = IoModule(
            self.module_net,
            node_id,
            sim_rig,
            settings=DeviceSettings(sync_period_us=round(self.period_s * 1e6), sync_counter_overflow=0),
        )
        self.module.start()
        self.rig_net = canopen.Network(can.Bus(interface="virtual", channel=channel))
        self.rig_net.connect()
        self.io = IoRig(
            cfg,
            transport=None,
            controller_id=CONTROLLER[role],
            period_s=self.period_s,
            lockstep=True,
            network=self.rig_net,
        ).start()
        self.I_max_A = self.io.I_max_A
        with self.module.device.lock:
            self.module._convert()
        self._last = self.io.read_sdo()
        self._pending = False

    def read(self):
        if self._pending:
            self._pending = False
            self._last = self.io.read()
        return self._last

    def apply_current(self, current_A: float) -> None:
        self.io.apply_current(current_A)

    def advance(self, dt_s: float) -> None:
        self.rig_net.sync.transmit()
        self._pending = True

    def __getattr__(self, name: str) -> Any:  # truth, bodies, t_s, schedule: the simulated rig's
        return getattr(self.sim, name)

    def close(self) -> None:
        self.io.close()
        self.module.close()
        self.module_net.disconnect()
        self.rig_net.disconnect()


def headline(duration_s: float | None = None) -> dict:
    """Direct rig vs rig behind in-process I/O modules on the §5.3 scene: the headlines and their ratio."""
    direct = run_offline_session(SCENE, rounding="real32", duration_s=duration_s)
    sides: list[InProcessIoSide] = []

    def path(rig, role):
        sides.append(InProcessIoSide(rig, role, f"io-bench-{os.getpid()}-{role}"))
        return sides[-1]

    t0 = time.perf_counter()
    try:
        via_io = run_offline_session(SCENE, rounding="real32", duration_s=duration_s, rig_path=path)
    finally:
        for s in sides:
            s.close()
    wall = time.perf_counter() - t0
    h_direct = direct.figures["transparency"]["headline_error_C"]
    h_io = via_io.figures["transparency"]["headline_error_C"]
    timeouts = sum(s.io.timeouts for s in sides)
    return {
        "io_rig_headline_C": h_io,
        "direct_rig_headline_C": h_direct,
        "io_rig_headline_ratio_to_direct_rig": h_io / h_direct,
        "io_rig_headline_method": "in-process: IoModule + IoRig on a python-can virtual channel per "
        "side, offline runner's telepresence loop, REAL32 exchange",
        "io_rig_headline_input_timeouts": timeouts,
        "io_rig_headline_wall_s": wall,
    }


def bus_load_4_nodes(cycles: int = 1000) -> dict:
    """Four processes over the hub in real time at 100 Hz: frames per COB-ID per second, the bus load."""
    bin_dir = Path(sys.executable).parent
    procs: list[subprocess.Popen] = []
    with HubThread() as hub:
        bus = f"socketcand://127.0.0.1:{hub.port}/vcan0"
        frames: list[tuple[float, int, int]] = []
        listen = can.Bus(
            interface="socketcand", host="127.0.0.1", port=hub.port, channel="vcan0", tcp_tune=True
        )

        def on_frame(msg: can.Message) -> None:
            frames.append((time.monotonic(), msg.arbitration_id, msg.dlc))

        notifier = can.Notifier(listen, [on_frame])
        try:
            _start_io_modules(bin_dir, bus, procs)
            time.sleep(3.0)  # the modules' boot (imports, scene): the drivers' SDO waits 1 s per request
            args = ["--rig", "io", "--timing", "realtime", "--bus", bus]
            procs.append(
                subprocess.Popen(
                    [
                        str(bin_dir / "telethermo-slave"),
                        *args,
                        "--rig-config",
                        str(bus_config_path(TOML["slave"])),
                    ],
                    stderr=subprocess.DEVNULL,
                )
            )
            master = subprocess.run(
                [
                    str(bin_dir / "telethermo-master"),
                    *args,
                    "--rig-config",
                    str(bus_config_path(TOML["master"])),
                    "--cycles",
                    str(cycles),
                    "--json",
                ],
                capture_output=True,
                text=True,
                timeout=300,
            )
            result = next(
                (
                    RunResult.from_line(line)
                    for line in master.stdout.splitlines()
                    if line.startswith(RESULT_PREFIX)
                ),
                None,
            )
            if master.returncode != 0 or result is None:
                raise RuntimeError(f"master failed ({master.returncode}): {master.stderr.strip()[-400:]}")
        finally:
            _stop_all(procs)
            notifier.stop()
            listen.shutdown()
    return _load_figures(frames, result)


def _start_io_modules(bin_dir: Path, bus: str, procs: list[subprocess.Popen]) -> None:
    """One ``telethermo-iomodule`` process per side, its node-ID from the side's RIG.toml, added to
    ``procs`` as it starts (so that a failure stops those already started)."""
    for role, toml in TOML.items():
        node_id = load_rig_config(bus_config_path(toml)).modules["io"].node_id
        procs.append(
            subprocess.Popen(
                [
                    str(bin_dir / "telethermo-iomodule"),
                    "--node-id",
                    str(node_id),
                    "--scene",
                    SCENE,
                    "--side",
                    role,
                    "--bus",
                    bus,
                ],
                stderr=subprocess.DEVNULL,
            )
        )


def _stop_all(procs: list[subprocess.Popen]) -> None:
    """SIGTERM to each process still running, then wait 20 s each (kill past that)."""
    for p in procs:
        if p.poll() is None:
            p.send_signal(signal.SIGTERM)
    for p in procs:
        try:
            p.wait(timeout=20)
        except subprocess.TimeoutExpired:
            p.kill()


def _load_figures(frames: list[tuple[float, int, int]], result: RunResult) -> dict:
    """Bus load and frames per cycle over the steady state, from the frames seen (monotonic s, COB-ID,
    DLC) and the master's result."""
    # the steady state: the frames from the first to the last SYNC (not the commissioning's SDO)
    syncs = [t for t, cob, _ in frames if cob == 0x80]
    window = [(cob, dlc) for t, cob, dlc in frames if syncs[0] <= t < syncs[-1]]
    wall_s = syncs[-1] - syncs[0]
    n_sync = len(syncs) - 1
    by_dlc = collections.Counter(dlc for _, dlc in window)
    by_cob = collections.Counter(cob for cob, _ in window)
    return {
        "io_rig_bus_load_100hz": bus_load({d: n / wall_s for d, n in by_dlc.items()}, DEFAULT_BITRATE),
        "io_rig_bus_load_per_cycle": bus_load(
            {d: n / n_sync * 100 for d, n in by_dlc.items()}, DEFAULT_BITRATE
        ),
        # issue 24 names the 60 s figure; a shorter (quick) session reports under the plain name
        (
            "io_rig_late_cycles_100hz_60s" if result.cycles >= 6000 else "io_rig_late_cycles_100hz"
        ): result.late_cycles,
        "io_rig_session_cycles": result.cycles,
        "io_rig_session_wall_s": wall_s,
        "io_rig_frames_per_cycle": {
            f"0x{cob:03X}": round(n / n_sync, 3) for cob, n in sorted(by_cob.items())
        },
        "io_rig_bus_bitrate": DEFAULT_BITRATE,
    }
