"""Both node programs as separate OS processes on a real SocketCAN vcan, in lockstep: trajectories
equal the offline runner's (REAL32 exchange) and candump (can-utils) counts the expected frames.

One short run (the group runs inside a slow VM where the kernel has no vcan on the host)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from telethermo.nodes.launch import NodePair, PairConfig
from telethermo.recording.merge import merge_recordings
from telethermo.offline import run_offline_session
from telethermo.recording.format import TEXT_COLUMNS

pytestmark = [pytest.mark.vcan, pytest.mark.slow]

SCENE = Path(__file__).resolve().parents[2] / "sim" / "scenes" / "probe_touches_al_steel_wood.toml"
CYCLES = 200


def test_two_processes_on_vcan_equal_offline_and_candump_agrees(
    vcan_channel, candump, tmp_path, slow_network
):
    dump = candump()
    time.sleep(1.0)  # candump gives no sign that it listens: time for it to bind its socket
    pair = NodePair(
        PairConfig(
            scene=SCENE,
            out_dir=tmp_path,
            bus=f"socketcan:{vcan_channel}",
            cycles=CYCLES,
            seed=0,
            network=slow_network,
            master_args=["--wait-peer", "300"],
        )
    )
    with pair:
        assert pair.wait_master(timeout_s=900) == 0, (tmp_path / "master.log").read_text()
    codes = pair.stop()
    assert codes == {"master": 0, "slave": 0}
    time.sleep(0.5)  # candump shows nothing until it stops: time to read the last frames
    frames = dump.stop()

    rec = merge_recordings(tmp_path / "master.csv", tmp_path / "slave.csv", scene=SCENE)
    off = run_offline_session(SCENE, duration_s=CYCLES * 0.01, rounding="real32", seed=0).recording
    assert len(rec) == len(off) == CYCLES
    np.testing.assert_array_equal(
        rec.col("sync_cycle"), np.arange(CYCLES)
    )  # one row per SYNC, numbered alike
    for c in rec.columns:
        if c == "sync_cycle":
            continue  # the nodes' own column: the offline runner has none
        if c in TEXT_COLUMNS:
            assert rec.text(c) == off.text(c), c
        else:
            a, b = rec.col(c), off.col(c)
            assert np.array_equal(np.isnan(a), np.isnan(b)), c
            np.testing.assert_allclose(a[np.isfinite(a)], b[np.isfinite(b)], rtol=0, atol=1e-9, err_msg=c)

    # candump, a client no one here wrote: one SYNC per cycle with a counter, one TPDO1 per node per SYNC
    syncs = [d for i, d in frames if i == 0x080]
    tpdo_m = [d for i, d in frames if i == 0x181]
    tpdo_s = [d for i, d in frames if i == 0x182]
    assert len(syncs) == CYCLES
    assert [d[0] for d in syncs] == [(k % 240) + 1 for k in range(CYCLES)]
    assert len(tpdo_m) == CYCLES and len(tpdo_s) == CYCLES
    assert all(len(d) == 8 for d in tpdo_m + tpdo_s)
    # the master's TPDO1 payloads are its recorded estimate and flux as REAL32
    est = np.frombuffer(b"".join(d[:4] for d in tpdo_m), "<f4").astype(float)
    np.testing.assert_array_equal(est, rec.col("m_estimate_C").astype(np.float32).astype(float))
    # boot-ups of both nodes and NMT start were on the bus
    assert (0x701, b"\x00") in frames and (0x702, b"\x00") in frames
    assert any(i == 0x000 and d[0] == 0x01 for i, d in frames)
