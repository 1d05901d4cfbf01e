"""No drift on the nodes (issue 11): two node processes over the hub, the finger lifted at 5 s, the probe in
air; both pads settle at neutral. The same scene as tests/offline/test_no_drift.py, through CAN."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from telethermo.nodes.launch import NodePair, PairConfig
from telethermo.recording.merge import merge_recordings
from telethermo.control.params import default_params
from telethermo.control.types import Role

pytestmark = pytest.mark.slow

SCENE = Path(__file__).resolve().parents[2] / "sim" / "scenes" / "finger_lifted.toml"
CYCLES = 4000  # 40 s


def test_pads_in_air_stay_at_neutral_on_the_nodes(tmp_path):
    pair = NodePair(PairConfig(scene=SCENE, out_dir=tmp_path, cycles=CYCLES, seed=0))
    with pair:
        assert pair.wait_master(timeout_s=300) == 0, (tmp_path / "master.log").read_text()
    pair.stop()
    rec = merge_recordings(tmp_path / "master.csv", tmp_path / "slave.csv", scene=SCENE)
    assert len(rec) == CYCLES
    t = rec.col("t_s")
    neutral = default_params(Role.MASTER).safety.neutral_C
    for side in ("m", "s"):
        T = rec.col(f"{side}_T_sensor_C")[t >= 15.0]
        assert np.max(np.abs(T - neutral)) <= 1.0, side
    # the probe never touched: its contact flag stayed 0 on the bus, the master rendered air then held neutral
    assert np.nanmax(rec.col("s_contact")) == 0.0
