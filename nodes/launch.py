"""Starting and stopping the two node processes (and the hub when no real bus is given).

Used by ``telethermo session``, the two-process tests and the benchmark, so that they all run the
same thing: the real console programs as separate OS processes on a real transport.

Order: hub (if needed) -> the I/O modules (``--io``: nodes.iomodules) -> slave -> master (the SYNC
producer waits for the slave's boot-up, starts it with NMT, then runs its cycles and exits) -> the slave
is stopped with SIGTERM -> the modules -> the hub with SIGTERM. Every child runs in its own process
group, so a terminal's Ctrl-C reaches only the caller, which then stops the children in that order
(:meth:`NodePair.stop`). The hub also stops by itself when its parent ends.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from telethermo.nodes.children import readline_within, stop_process
from telethermo.nodes.iomodules import IoModuleError, IoModuleProcess
from telethermo.recording.result import RESULT_PREFIX, RunResult

HUB_CHANNEL = "telethermo"


class LaunchError(RuntimeError):
    """A child process could not be started or failed."""


class HubProcess:
    """``telethermo-hub`` as a child process on a free loopback port."""

    def __init__(
        self,
        *,
        idle_timeout_s: float = 60.0,
        log_path: Path | None = None,
        publish: bool = False,
        port: int = 0,
    ) -> None:
        """``publish``: let the hub publish where it listens (telethermo.transport.published); off for
        tests and benchmarks, which give their clients ``--bus`` and must not redirect the user's commands.
        ``port``: the TCP port (0: a free one), e.g. a hub restarted where the nodes look for it."""
        self.idle_timeout_s = idle_timeout_s
        self.requested_port = port
        self.publish = publish
        self.log_path = log_path
        self.proc: subprocess.Popen | None = None
        self.port: int | None = None

    def start(self, timeout_s: float = 30.0) -> int:
        cmd = [
            sys.executable,
            "-m",
            "telethermo.transport.hub",
            "--port",
            str(self.requested_port),
            "--parent-pid",
            str(os.getpid()),
            "--idle-timeout",
            f"{self.idle_timeout_s:g}",
            "--channel",
            HUB_CHANNEL,
        ]
        if not self.publish:
            cmd.append("--no-publish")
        self.proc = subprocess.Popen(
            cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True
        )
        line = readline_within(self.proc, timeout_s)
        if not line.startswith("telethermo-hub listening on "):
            self.stop()
            raise LaunchError(f"telethermo-hub did not start: {line.strip() or 'no output'}")
        self.port = int(line.rsplit(":", 1)[1])
        # keep draining its output (its final statistics line) into the log
        threading.Thread(target=self._drain, daemon=True).start()
        return self.port

    def _drain(self) -> None:
        assert self.proc is not None and self.proc.stdout is not None
        sink = open(self.log_path, "a", encoding="utf-8") if self.log_path else None
        try:
            for line in self.proc.stdout:
                if sink:
                    sink.write(line)
                    sink.flush()
        finally:
            if sink:
                sink.close()

    @property
    def bus(self) -> str:
        return f"socketcand://127.0.0.1:{self.port}/{HUB_CHANNEL}"

    def stop(self) -> None:
        stop_process(self.proc, timeout_s=5.0)


def node_command(role: str, *args: str) -> list[str]:
    """The command line of a node program run with this interpreter (same as the console script)."""
    return [sys.executable, "-m", f"telethermo.nodes.{role}", *args]


def start_lone_node(
    role: str, scene: Path, out_dir: Path, *bus_args: str, mode: str = "idle", timing: str = "lockstep"
) -> subprocess.Popen:
    """One node program alone until stopped (``--cycles 0``, no wait for a peer), e.g. the master a
    ``telethermo identify`` talks to; ``bus_args``: ``--bus B`` or ``--network FILE``. Its log goes to
    ``out_dir/<role>.log`` and its stderr to ``out_dir/<role>-stderr.log``. Stop it with
    :func:`stop_process`."""
    out_dir.mkdir(parents=True, exist_ok=True)
    return subprocess.Popen(
        node_command(
            role,
            *bus_args,
            "--scene",
            str(scene),
            "--mode",
            mode,
            "--cycles",
            "0",
            "--timing",
            timing,
            "--wait-peer",
            "0",
            "--log",
            str(out_dir / f"{role}.log"),
            "--store",
            str(out_dir / f"{role}-store.json"),
        ),
        stdout=subprocess.DEVNULL,
        stderr=open(out_dir / f"{role}-stderr.log", "ab"),
        start_new_session=True,
    )


@dataclass
class PairConfig:
    """What :class:`NodePair` runs.

    Attributes:
        scene: scene file of both simulated rigs.
        out_dir: where recordings (master.csv, slave.csv) and logs go.
        bus: transport string; None = start our hub and use it.
        network, model: files passed to both nodes (None: packaged defaults).
        mode: initial mode name of both nodes.
        timing: "lockstep" or "realtime".
        cycles: cycles the master runs (None: the scene's duration).
        seed: noise seed (the slave gets seed + 1 so the rigs' noises differ).
        progress_every: the master prints ``progress k n`` every this many cycles.
        master_args, slave_args: further arguments for each node program.
        io: each controller drives its side's simulated I/O module (a ``telethermo-iomodule`` process, the
            scene's rig behind it, nodes.iomodules) with ``--rig io --rig-config`` its packaged RIG.toml,
            instead of a simulated rig in its own process.
        io_faults: ``--fault`` texts of each side's module (telethermo.iomodule.faults), e.g.
            ``{"master": ["detach:5"]}``.
        io_rig_configs: a side's RIG.toml instead of its packaged one (nodes.iomodules.rig_config), e.g.
            longer heartbeat-consumer times for a slow machine.
        io_ready_s: how long the modules (booting side by side) may take to answer, s.
    """

    scene: Path
    out_dir: Path
    bus: str | None = None
    network: Path | None = None
    model: Path | None = None
    mode: str = "telepresence"
    timing: str = "lockstep"
    cycles: int | None = None
    seed: int | None = None
    progress_every: int = 100
    master_args: list[str] = field(default_factory=list)
    slave_args: list[str] = field(default_factory=list)
    io: bool = False
    io_faults: dict[str, list[str]] = field(default_factory=dict)
    io_rig_configs: dict[str, Path] = field(default_factory=dict)
    io_ready_s: float = 60.0


class NodePair:
    """The master and slave node processes of one session."""

    def __init__(self, config: PairConfig) -> None:
        self.config = config
        self.hub: HubProcess | None = None
        self.master: subprocess.Popen | None = None
        self.slave: subprocess.Popen | None = None
        self.bus: str | None = config.bus
        self.progress: tuple[int, int] = (0, 0)
        self._progress_lock = threading.Lock()
        self._master_lines: list[str] = []
        self.result: RunResult | None = None
        """The master's ``result {json}`` line (cycles, wall time, late cycles, latencies), typed."""
        self._reader: threading.Thread | None = None
        self.modules: dict[str, IoModuleProcess] = {}
        """The I/O module processes by side (``config.io``)."""

    @property
    def out_dir(self) -> Path:
        return self.config.out_dir

    def recording(self, role: str) -> Path:
        return self.out_dir / f"{role}.csv"

    def log(self, role: str) -> Path:
        return self.out_dir / f"{role}.log"

    def _common(self, role: str) -> list[str]:
        c = self.config
        # a session of simulated rigs keeps its parameter store in its own folder: settings a lab saved for
        # its hardware nodes (the per-user default store) never change a session's figures
        rig = (
            ["--rig", "io", "--rig-config", str(self.modules[role].config)]
            if c.io
            else ["--scene", str(c.scene)]
        )
        args = [
            "--bus",
            self.bus,
            *rig,
            "--record",
            str(self.recording(role)),
            "--mode",
            c.mode,
            "--timing",
            c.timing,
            "--log",
            str(self.log(role)),
            "--store",
            str(self.out_dir / f"{role}-store.json"),
        ]
        if c.network is not None:
            args += ["--network", str(c.network)]
        if c.model is not None:
            args += ["--model", str(c.model)]
        if c.seed is not None and not c.io:  # the I/O module simulates the rig: the seed is its
            args += ["--seed", str(self._seed(role))]
        return args

    def _seed(self, role: str) -> int | None:
        seed = self.config.seed
        return None if seed is None else seed + (1 if role == "slave" else 0)

    def start_modules(self) -> None:
        """``config.io``: the I/O module of each side that runs (the slave's only in telepresence), booting
        side by side, each up and answering (within ``config.io_ready_s``) before its controller commissions
        it."""
        c = self.config
        assert self.bus is not None
        for role in ("slave", "master") if c.mode != "render" else ("master",):
            self.modules[role] = IoModuleProcess(
                role,
                c.scene,
                self.bus,
                self.out_dir,
                seed=self._seed(role),
                network=c.network,
                config=c.io_rig_configs.get(role),
                faults=c.io_faults.get(role, []),
            )
            self.modules[role].launch()
        deadline = time.monotonic() + c.io_ready_s
        for mod in self.modules.values():
            try:
                mod.wait_ready(max(1.0, deadline - time.monotonic()))
            except IoModuleError as exc:
                for other in self.modules.values():  # the ones launched beside it
                    other.stop()
                raise LaunchError(str(exc)) from None

    def start_slave(self) -> subprocess.Popen:
        """(Re)start the slave process."""
        self.slave = subprocess.Popen(
            node_command("slave", *self._common("slave"), *self.config.slave_args),
            stdout=subprocess.DEVNULL,
            stderr=open(self.log("slave-stderr"), "ab"),
            start_new_session=True,
        )
        return self.slave

    def start(self) -> None:
        c = self.config
        self.out_dir.mkdir(parents=True, exist_ok=True)
        for role in ("master", "slave"):
            for p in (self.log(role), self.log(f"{role}-stderr")):
                p.unlink(missing_ok=True)
        if self.bus is None:
            self.hub = HubProcess(log_path=self.log("hub"))
            self.hub.start()
            self.bus = self.hub.bus
        if c.io:
            self.start_modules()
        if c.mode != "render":  # virtual rendering: the master alone
            self.start_slave()
        margs = self._common("master") + ["--progress", str(c.progress_every), "--json"]  # the result line
        if c.cycles is not None:
            margs += ["--cycles", str(c.cycles)]
        self.master = subprocess.Popen(
            node_command("master", *margs, *c.master_args),
            stdout=subprocess.PIPE,
            stderr=open(self.log("master-stderr"), "ab"),
            text=True,
            start_new_session=True,
        )
        self._reader = threading.Thread(target=self._read_master, daemon=True)
        self._reader.start()

    def _read_master(self) -> None:
        assert self.master is not None and self.master.stdout is not None
        for line in self.master.stdout:
            parts = line.split()
            if len(parts) == 3 and parts[0] == "progress":
                with self._progress_lock:
                    self.progress = (int(parts[1]), int(parts[2]))
            elif line.startswith(RESULT_PREFIX):
                self.result = RunResult.from_line(line, "telethermo-master's result line")
            else:
                self._master_lines.append(line.rstrip("\n"))

    def master_output(self) -> list[str]:
        return list(self._master_lines)

    def wait_master(self, timeout_s: float | None = None) -> int:
        """Wait for the master to finish its cycles; return its exit code."""
        assert self.master is not None
        code = self.master.wait(timeout=timeout_s)
        if self._reader is not None:
            self._reader.join(timeout=5)
        return code

    def stop(self, *, sig: int = signal.SIGTERM) -> dict[str, int | None]:
        """Stop master, then slave, then the hub (SIGTERM: each node cuts its current, sends its
        last heartbeat and closes its recording); return the exit codes."""
        codes = {"master": stop_process(self.master, sig=sig), "slave": stop_process(self.slave, sig=sig)}
        for role, mod in self.modules.items():
            codes[f"io-{role}"] = mod.stop()
        if self.hub is not None:
            self.hub.stop()
            codes["hub"] = self.hub.proc.returncode if self.hub.proc else None
        return codes

    def __enter__(self) -> "NodePair":
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


def wait_for(predicate, timeout_s: float, poll_s: float = 0.05) -> bool:
    """Poll ``predicate`` until true or ``timeout_s`` passed."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(poll_s)
    return bool(predicate())
