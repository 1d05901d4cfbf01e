"""The simulated I/O modules of a session (``telethermo session --io``): one ``telethermo-iomodule`` process
per side, with that side's rig of the scene behind its channels, beside the two controller nodes that drive
them with ``--rig io --rig-config RIG.toml`` (docs/hardware.md).

The module of a side is the one its RIG.toml names (``modules.<name>.node_id`` of the drive's module: 3 for
the master's packaged ``rig_io_sim.toml``, 4 for the slave's ``rig_io_sim_slave.toml``). Each module writes
the simulated plant's truth per SYNC (``--record``, :mod:`telethermo.iomodule.truthlog`); :func:`fill_truth`
puts it into the merged session recording, where a controller on ``--rig io`` recorded NaN.
"""

from __future__ import annotations

import subprocess
import sys
import threading
from pathlib import Path

import numpy as np

from telethermo.bus_config import path as bus_config_path
from telethermo.iomodule.rigconfig import load_rig_config
from telethermo.iomodule.truthlog import read_truth_log
from telethermo.recording.format import Recording

from telethermo.nodes.children import readline_within, stop_process

#: the packaged RIG.toml of each side on the simulated modules
RIG_CONFIGS = {"master": "rig_io_sim.toml", "slave": "rig_io_sim_slave.toml"}
READY = "telethermo-iomodule node "


class IoModuleError(RuntimeError):
    """A module process did not come up (the message names it and its log)."""


def rig_config(side: str) -> Path:
    """The packaged RIG.toml of ``side``'s controller."""
    return Path(bus_config_path(RIG_CONFIGS[side]))


class IoModuleProcess:
    """``telethermo-iomodule`` for ``side`` of ``scene`` on ``bus``, as a child process: :meth:`start` returns
    when the module answers (its ready line), :meth:`stop` ends it (SIGTERM, then SIGKILL)."""

    def __init__(
        self,
        side: str,
        scene: Path,
        bus: str,
        out_dir: Path,
        *,
        seed: int | None = None,
        network: Path | None = None,
        config: Path | None = None,
        faults: list[str] | None = None,
    ) -> None:
        self.side = side
        self.config = config if config is not None else rig_config(side)
        cfg = load_rig_config(self.config)
        self.node_id = cfg.modules[cfg.drive.module].node_id
        self.truth_path = out_dir / f"io-{side}-truth.csv"
        self.log_path = out_dir / f"io-{side}.log"
        self.cmd = [
            sys.executable,
            "-m",
            "telethermo.iomodule.main",
            "--node-id",
            str(self.node_id),
            "--scene",
            str(scene),
            "--side",
            side,
            "--bus",
            bus,
            "--record",
            str(self.truth_path),
        ]
        if seed is not None:
            self.cmd += ["--seed", str(seed)]
        if network is not None:
            self.cmd += ["--network", str(network)]
        for fault in faults or []:
            self.cmd += ["--fault", fault]
        self.proc: subprocess.Popen[str] | None = None

    def start(self, timeout_s: float = 60.0) -> None:
        """Start the process and wait for its ready line (:meth:`launch`, then :meth:`wait_ready`)."""
        self.launch()
        self.wait_ready(timeout_s)

    def launch(self) -> None:
        """Start the process, not waiting for it (several modules boot side by side)."""
        self.log_path.unlink(missing_ok=True)
        self.truth_path.unlink(missing_ok=True)
        self.proc = subprocess.Popen(
            self.cmd,
            stdout=subprocess.PIPE,
            stderr=open(self.log_path, "ab"),
            text=True,
            start_new_session=True,
        )

    def wait_ready(self, timeout_s: float = 60.0) -> None:
        """Wait at most ``timeout_s`` s for the launched module's ready line (IoModuleError, the process
        stopped, when it does not come)."""
        assert self.proc is not None
        if not readline_within(self.proc, timeout_s).startswith(READY):
            code = self.stop()
            raise IoModuleError(
                f"the {self.side}'s I/O module (node {self.node_id}) did not come up within {timeout_s:g} s "
                f"(exit {code}); see {self.log_path}"
            )
        threading.Thread(target=lambda: self._stdout().read(), daemon=True).start()  # keep the pipe drained

    def _stdout(self):  # type: ignore[no-untyped-def]
        assert self.proc is not None and self.proc.stdout is not None
        return self.proc.stdout

    def stop(self, timeout_s: float = 10.0) -> int | None:
        """End the module (SIGTERM, SIGKILL after ``timeout_s`` s); its exit code, None if never launched."""
        return stop_process(self.proc, timeout_s=timeout_s)


def fill_truth(rec: Recording, truth_csv: Path) -> int:
    """The columns of a module's truth log into ``rec`` (rows matched on ``sync_cycle``; a row the module did
    not log stays NaN); returns the rows filled. ValueError: a bad log, or a recording without sync_cycle."""
    log = read_truth_log(truth_csv)
    if "sync_cycle" not in rec.columns:
        raise ValueError(f"{truth_csv}: the session recording has no sync_cycle column to match on")
    where = {int(c): i for i, c in enumerate(log["sync_cycle"])}
    cycles = np.asarray(rec.columns["sync_cycle"], dtype=float)
    rows = np.asarray([where.get(int(c), -1) if np.isfinite(c) else -1 for c in cycles], dtype=int)
    have = rows >= 0
    for name, values in log.items():
        if name in ("sync_cycle", "t_s"):
            continue
        col = np.full(len(cycles), np.nan)
        col[have] = np.asarray(values, dtype=float)[rows[have]]
        rec.columns[name] = col
    return int(have.sum())
