"""The monitor benchmark on a short run: its traffic (telethermo.monitor.traffic) is what the monitor decodes
without complaint, and ``python -m bench.monitor_bench``, run as the program (tests do not import bench/),
writes the result keys the issue names."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from telethermo.monitor.state import Monitor
from telethermo.monitor.traffic import monitor_config, traffic

ROOT = Path(__file__).resolve().parents[2]


def test_the_benchmark_traffic_decodes_cleanly():
    frames = traffic(5000)
    mon = Monitor(monitor_config())
    for m in frames:
        mon.feed(m)
    s = mon.stats
    assert s.frames == 5000 and s.unknown_frames == 0 and s.malformed == 0 and s.missed_pdos == 0
    assert s.late_cycles == 0 and s.syncs > 900
    assert {n: st.nmt_state for n, st in mon.nodes.items()} == {1: "OPERATIONAL", 2: "OPERATIONAL"}
    assert mon.nodes[1].sdo_ok == len([m for m in frames if m.arbitration_id == 0x581])
    assert mon.nodes[2].emcys == 2


def bench(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, **(env or {})},
    )


@pytest.mark.slow  # starts the benchmark, which starts a hub and a sender process
def test_quick_run_writes_the_result_keys(tmp_path):
    p = bench(
        "bench.monitor_bench", "--quick", "--frames", "3000", env={"TELETHERMO_BENCH_RESULTS": str(tmp_path)}
    )
    assert p.returncode == 0, p.stderr[-2000:]
    data = json.loads((tmp_path / "monitor.json").read_text())
    assert data["frames"] == 3000 and data["repeats"] == 3
    assert (
        data["decode_frames_per_s"] > 0 and data["anchor_frames_per_s"] > 0 and data["live_frames_per_s"] > 0
    )
    assert abs(data["ratio_vs_anchor"] - data["decode_frames_per_s"] / data["anchor_frames_per_s"]) < 1e-3
    assert data["keeps_up_8k"] == (min(data["decode_frames_per_s"], data["live_frames_per_s"]) >= 8000)
    # live over a real hub process, fed by a separate sender process: nothing lost, both rates measured
    assert data["hub_frames_lost"] == 0 and data["hub_frames"] == 5000
    assert data["hub_anchor_frames_per_s"] > 0 and data["hub_live_frames_per_s"] > 0
    assert data["hub_keeps_up_8k"] == (data["hub_live_frames_per_s"] >= 8000)


@pytest.mark.slow  # starts the bench program
def test_the_suite_runs_the_monitor_benchmark():
    """``python -m bench --only monitor`` is accepted: the monitor benchmark is in the suite's list."""
    p = bench("bench", "--help")
    assert p.returncode == 0, p.stderr
    choices = p.stdout.split("--only", 1)[1].split("{", 1)[1].split("}", 1)[0].split(",")
    assert "monitor" in choices, p.stdout
