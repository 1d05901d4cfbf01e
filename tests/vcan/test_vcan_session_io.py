"""``telethermo session --io``'s four processes on a real SocketCAN vcan (issue 24 item 2): the two
controllers on ``--rig io`` driving two ``telethermo-iomodule`` processes, in lockstep; candump (can-utils,
a client no one here wrote) sees every cycle's module TPDOs and drive RPDOs and the modules' heartbeats, and
the merged recording holds the modules' truth. Skipped where the kernel has no vcan (run inside
../shared/tools/vcan-run). The packaged network settings, not the slow VM's: the modules' heartbeat
consumers (0x1016, 150 ms from the packaged RIG.toml) watch the controllers' heartbeats, which the slow
settings space 200 ms apart.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from telethermo.nodes.iomodules import fill_truth
from telethermo.nodes.launch import NodePair, PairConfig
from telethermo.recording.merge import merge_recordings

pytestmark = [
    pytest.mark.vcan,
    pytest.mark.slow,
    pytest.mark.skip(
        reason="not yet green in ../shared/tools/vcan-run: in the emulated VM "
        "the four "
        "processes' lockstep session did not finish within the VM's 1500 s budget "
        "(seen 2026-11-26); the four-node session is tested over the hub "
        "(tests/nodes/test_session_io.py). Open gap of issue 24."
    ),
]

SCENE = Path(__file__).resolve().parents[2] / "sim" / "scenes" / "probe_touches_al_steel_wood.toml"
CYCLES = 200


def test_four_node_session_on_vcan(vcan_channel, candump, tmp_path):
    dump = candump()
    time.sleep(1.0)
    pair = NodePair(
        PairConfig(
            scene=SCENE,
            out_dir=tmp_path,
            bus=f"socketcan:{vcan_channel}",
            cycles=CYCLES,
            seed=0,
            master_args=["--wait-peer", "300"],
            io=True,
        )
    )
    with pair:
        assert pair.wait_master(timeout_s=900) == 0, (tmp_path / "master.log").read_text()
    codes = pair.stop()
    assert codes["master"] == 0 and codes["slave"] == 0 and codes["io-master"] == 0 and codes["io-slave"] == 0
    time.sleep(0.5)
    frames = dump.stop()
    count = {cob: sum(1 for i, _ in frames if i == cob) for cob in (0x183, 0x283, 0x184, 0x284, 0x203, 0x204)}
    assert all(n >= CYCLES for n in count.values()), count
    assert any(i == 0x703 for i, _ in frames) and any(i == 0x704 for i, _ in frames)
    rec = merge_recordings(tmp_path / "master.csv", tmp_path / "slave.csv", scene=SCENE)
    assert fill_truth(rec, pair.modules["master"].truth_path) == len(rec) == CYCLES
    assert fill_truth(rec, pair.modules["slave"].truth_path) == CYCLES
    assert np.all(np.isfinite(rec.col("m_true_finger_C")))
