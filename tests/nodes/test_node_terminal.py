"""Issue 25, what a node's terminal shows: one line when it is ready (its bus, what it waits for), and at the
end
a short table, the ``result {json}`` line only with ``--json`` (what the session launcher passes and reads).
Real processes: our hub, the slave and the master programs (lockstep, pads in air, 300 cycles)."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from telethermo.nodes.launch import HubProcess, node_command, stop_process, wait_for
from telethermo.recording.result import RunResult

pytestmark = pytest.mark.slow
SCENE = Path(__file__).resolve().parents[2] / "sim" / "scenes" / "pads_in_air.toml"


def _run_pair(tmp_path: Path, *master_args: str) -> tuple[str, str, str]:
    """(master stdout, master stderr, slave stderr) of a 300-cycle telepresence run."""
    hub = HubProcess(log_path=tmp_path / "hub.log")
    hub.start()
    slave_err = tmp_path / "slave-stderr.log"
    slave = subprocess.Popen(
        node_command("slave", "--bus", hub.bus, "--scene", str(SCENE), "--timing", "lockstep"),
        stdout=subprocess.DEVNULL,
        stderr=open(slave_err, "wb"),
        start_new_session=True,
    )
    try:
        assert wait_for(lambda: "ready on" in slave_err.read_text(), 60), slave_err.read_text()
        master = subprocess.run(
            node_command(
                "master",
                "--bus",
                hub.bus,
                "--scene",
                str(SCENE),
                "--timing",
                "lockstep",
                "--cycles",
                "300",
                *master_args,
            ),
            capture_output=True,
            text=True,
            timeout=180,
        )
        assert master.returncode == 0, master.stderr
    finally:
        stop_process(slave)
        hub.stop()
    return master.stdout, master.stderr, slave_err.read_text()


def test_ready_lines_and_the_summary_table(tmp_path):
    out, err, slave_err = _run_pair(tmp_path)
    bus = "socketcand://127.0.0.1:"
    first = [ln for ln in err.splitlines() if "ready on" in ln]
    assert len(first) == 1 and first[0].startswith(f"node 1 ready on {bus}")
    assert first[0].endswith("/telethermo, waiting for the slave")
    ready = [ln for ln in slave_err.splitlines() if "ready on" in ln]
    assert len(ready) == 1 and ready[0].startswith(f"node 2 ready on {bus}")
    assert ready[0].endswith(", waiting for the master's SYNC")
    assert "{" not in out and "result" not in out
    lines = out.rstrip().splitlines()
    assert lines[0].startswith("  cycles             300 in ") and "lockstep, period 10 ms" in lines[0]
    assert any(ln.startswith("  late cycles        ") for ln in lines)
    assert lines[-1] == "  (--json: all figures as one JSON line)" and len(lines) <= 8


def test_json_flag_gives_the_machine_line(tmp_path):
    out, _, _ = _run_pair(tmp_path, "--json")
    results = [ln for ln in out.splitlines() if ln.startswith("result ")]
    assert len(results) == 1 and json.loads(results[0][len("result ") :])["cycles"] == 300
    # the typed result reads the real program's line and writes it back byte for byte
    r = RunResult.from_line(results[0])
    assert r.cycles == 300 and r.timing == "lockstep" and r.period_s == pytest.approx(0.01)
    assert r.realtime is None
    assert r.sync_to_tpdo_n > 0 and r.peer["pdos"] > 0
    assert r.to_line() == results[0]
