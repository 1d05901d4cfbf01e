"""Issue 25: live `telethermo identify` checked the pad's contact only at the start and the end; a probe that
touched something during the experiment gave a disturbed record that was fitted (and loaded when stable).

Real processes: our hub, a master node program with a wall-clock rig whose contact detector says touched while
a file exists (tests/nodes/rig_factories.py:touched_while_file), and `telethermo identify master` as its own
process. The test touches the pad once the experiment runs and lifts it before the end: the command refuses
with one line naming when contact was seen, exit 1 (the CLI's refusal of a node's state), nothing loaded, the
node put back in idle."""

from __future__ import annotations

import os
import re
import struct
import subprocess
import sys
from pathlib import Path

import pytest

from telethermo.cli.main import EXIT_FAIL, EXIT_OK, main
from telethermo.nodes.launch import HubProcess, node_command, stop_process, wait_for
from telethermo.transport.bus import FrameLog

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[2]
PERIOD_S = 0.01  # the packaged network's SYNC period
# 50 rest + 600 training + 300 held-out samples: 9.5 s of real time
PLAN = [
    "--rest",
    "50",
    "--samples",
    "600",
    "--validation",
    "300",
    "--hold",
    "5",
    "--orders",
    "2,2,0,0",
    "--method",
    "ls",
    "--quiet",
]
TOTAL = 950


def get(capsys, bus: str, name: str) -> int | None:
    code = main(["get", "--bus", bus, "--timeout", "1", "master", name])
    out = capsys.readouterr().out
    return int(float(out.split(" = ", 1)[1].split()[0])) if code == EXIT_OK else None


def stream_sample(witness: FrameLog) -> int:
    """The highest sample number of the identification stream on the bus (TPDO2 of node 1, COB-ID 0x281:
    ident_sample U32, T_sensor_C REAL32), as a bus analyser sees it (an SDO client of ours would share the
    command's SDO channel)."""
    ks = (struct.unpack_from("<I", d)[0] for _, c, d in witness.snapshot() if c == 0x281 and len(d) == 8)
    return max((k for k in ks if k <= TOTAL), default=0)  # before the remap, TPDO2 carries two REAL32


def test_a_touch_during_the_experiment_is_refused_with_when(tmp_path, capsys):
    flag = tmp_path / "touched"
    hub = HubProcess(idle_timeout_s=60, log_path=tmp_path / "hub.log")
    hub.start()
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    rig = "tests.nodes.rig_factories:touched_while_file"
    node = subprocess.Popen(
        node_command(
            "master",
            "--bus",
            hub.bus,
            "--rig",
            rig,
            "--rig-arg",
            f'flag="{flag}"',
            "--mode",
            "idle",
            "--cycles",
            "0",
            "--wait-peer",
            "0",
            "--log",
            str(tmp_path / "master.log"),
        ),
        stdout=subprocess.DEVNULL,
        stderr=open(tmp_path / "master-stderr.log", "ab"),
        env=env,
        cwd=ROOT,
        start_new_session=True,
    )
    ident = None
    witness = FrameLog(hub.bus)
    try:
        assert wait_for(lambda: get(capsys, hub.bus, "mode") == 0, 60), (
            tmp_path / "master-stderr.log"
        ).read_text()
        ident = subprocess.Popen(
            [sys.executable, "-m", "telethermo", "identify", "master", "--bus", hub.bus, *PLAN],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        # touch once the experiment is well under way, lift after at least 100 samples, before its end
        running = wait_for(lambda: ident.poll() is not None or stream_sample(witness) > 150, 60)
        assert running and ident.poll() is None, (
            ident.communicate() if ident.poll() is not None else "no sample"
        )
        k_on = stream_sample(witness)
        flag.touch()
        assert wait_for(lambda: stream_sample(witness) > k_on + 100, 30)
        flag.unlink()
        k_off = stream_sample(witness)
        assert k_off < 900, (
            "the experiment ended before the probe was lifted: the machine is too slow for this test"
        )
        out, err = ident.communicate(timeout=120)
        assert ident.returncode == EXIT_FAIL, err
        last = err.strip().splitlines()[-1]
        m = re.fullmatch(
            r"telethermo identify: master: contact at (\d+\.\d)-(\d+\.\d) s of the experiment: the fit "
            r"needs a free pad; lift the probe and run again \(nothing fitted or loaded\)",
            last,
        )
        assert m, err
        t_on, t_off = float(m.group(1)), float(m.group(2))
        # what the command saw lies within what the test did (seen on the bus around the touch), 0.2 s of
        # polling
        assert (k_on - 1) * PERIOD_S - 0.05 <= t_on and t_off <= (k_off - 1) * PERIOD_S + 0.25, (
            k_on,
            k_off,
            last,
        )
        assert t_off - t_on >= 100 * PERIOD_S - 0.25
        assert "model" not in out
        assert get(capsys, hub.bus, "model_status") == 0 and get(capsys, hub.bus, "mode") == 0
    finally:
        witness.close()
        if ident is not None and ident.poll() is None:
            stop_process(ident)
        stop_process(node)
        hub.stop()
