"""The monitor benchmark on a short run: its traffic is what the monitor decodes without complaint,
and its result file has the keys the issue names."""
from __future__ import annotations

import json

import pytest

from bench import monitor_bench
from bench.__main__ import SUITE
from telethermo.monitor.state import Monitor


def test_the_benchmark_traffic_decodes_cleanly():
    frames = monitor_bench.traffic(5000)
    mon = Monitor(monitor_bench.monitor_config())
    for m in frames:
        mon.feed(m)
    s = mon.stats
    assert s.frames == 5000 and s.unknown_frames == 0 and s.malformed == 0 and s.missed_pdos == 0
    assert s.late_cycles == 0 and s.syncs > 900
    assert {n: st.nmt_state for n, st in mon.nodes.items()} == {1: "OPERATIONAL", 2: "OPERATIONAL"}
    assert mon.nodes[1].sdo_ok == len([m for m in frames if m.arbitration_id == 0x581])
    assert mon.nodes[2].emcys == 2


@pytest.mark.slow  # starts a hub and a sender process
def test_quick_run_writes_the_result_keys(tmp_path, monkeypatch):
    monkeypatch.setenv("TELETHERMO_BENCH_RESULTS", str(tmp_path))
    monitor_bench.run(quick=True, n_frames=3000)
    data = json.loads((tmp_path / "monitor.json").read_text())
    assert data["frames"] == 3000 and data["repeats"] == 3
    assert data["decode_frames_per_s"] > 0 and data["anchor_frames_per_s"] > 0 and data["live_frames_per_s"] > 0
    assert abs(data["ratio_vs_anchor"] - data["decode_frames_per_s"] / data["anchor_frames_per_s"]) < 1e-3
    assert data["keeps_up_8k"] == (min(data["decode_frames_per_s"], data["live_frames_per_s"]) >= 8000)
    assert "monitor" in SUITE
    # live over a real hub process, fed by a separate sender process: nothing lost, both rates measured
    assert data["hub_frames_lost"] == 0 and data["hub_frames"] == 5000
    assert data["hub_anchor_frames_per_s"] > 0 and data["hub_live_frames_per_s"] > 0
    assert data["hub_keeps_up_8k"] == (data["hub_live_frames_per_s"] >= 8000)
