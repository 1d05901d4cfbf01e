"""``telethermo session --io``'s four processes on a real SocketCAN vcan (issue 24 item 2): the two
controllers on ``--rig io`` driving two ``telethermo-iomodule`` processes, in lockstep; candump (can-utils,
a client no one here wrote) sees every cycle's module TPDOs and drive RPDOs and the modules' heartbeats, and
the merged recording holds the modules' truth. Skipped where the kernel has no vcan (run inside
../shared/tools/vcan-run).

Settings for the emulated VM (10-20x slower than the host), on all four nodes: the slow network settings
(controllers' heartbeats 200 ms apart, consumers 3 s), the packaged RIG.toml files with the modules' heartbeat
consumers (0x1016) at 3 s instead of 150 ms and the commissioning's SDO answers awaited 20 s, the two modules
booting side by side and given 400 s to answer. Why: with the packaged 100 ms heartbeats and 150 ms consumers,
one late heartbeat puts a module in its error state (0x1029:1 = 0: PRE-OPERATIONAL, its TPDOs stop; nobody
starts it again), and from then on every read of its controller waits out the lockstep input timeout, 2.5 s
per cycle (reproduced on the hub by pausing the master 0.4 s: 8 cycles in the next 15 s): the run that did not
finish in the VM's 1500 s budget. And a module's imports alone take over 60 s in the VM, the launcher's former
wait for its ready line.
"""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

from telethermo.nodes.iomodules import fill_truth, rig_config
from telethermo.nodes.launch import NodePair, PairConfig
from telethermo.recording.merge import merge_recordings

pytestmark = [pytest.mark.vcan, pytest.mark.slow]

SCENE = Path(__file__).resolve().parents[2] / "sim" / "scenes" / "probe_touches_al_steel_wood.toml"
CYCLES = 100
SLOW_CONSUMER_MS = 3000
SLOW_SDO_MS = 20000
#: the whole session (the modules' boot included), s: a hang guard, inside vcan-run's 3600 s; beside two CPU
#: hogs in the emulated VM the master ran 447 s of its 100 lockstep cycles without finishing (600 s budget)
BUDGET_S = 1500.0


def slow_rig_configs(tmp_path: Path) -> dict[str, Path]:
    """Each side's packaged RIG.toml with the module's heartbeat consumer at ``SLOW_CONSUMER_MS`` and the
    commissioning's SDO answers awaited ``SLOW_SDO_MS``."""
    out = {}
    for side in ("master", "slave"):
        text = rig_config(side).read_text(encoding="utf-8")
        assert text.count("consumer_ms = 150") == 1 and "\nsdo_timeout_ms" not in text, side
        text = text.replace("consumer_ms = 150", f"consumer_ms = {SLOW_CONSUMER_MS}")
        p = tmp_path / f"rig-{side}.toml"
        p.write_text(f"sdo_timeout_ms = {SLOW_SDO_MS}\n{text}", encoding="utf-8")
        out[side] = p
    return out


def logs(tmp_path: Path) -> str:
    names = ("master.log", "master-stderr.log", "slave-stderr.log", "io-master.log", "io-slave.log")
    return "\n".join(
        f"--- {n}\n{(tmp_path / n).read_text()[-3000:]}" for n in names if (tmp_path / n).exists()
    )


def test_four_node_session_on_vcan(vcan_channel, candump, tmp_path, slow_network):
    dump = candump()
    time.sleep(1.0)  # candump gives no sign that it listens: time for it to bind its socket
    pair = NodePair(
        PairConfig(
            scene=SCENE,
            out_dir=tmp_path / "run",
            bus=f"socketcan:{vcan_channel}",
            cycles=CYCLES,
            seed=0,
            network=slow_network,
            master_args=["--wait-peer", "300"],
            io=True,
            io_rig_configs=slow_rig_configs(tmp_path),
            io_ready_s=400,
        )
    )
    t0 = time.monotonic()
    with pair:
        up_s = time.monotonic() - t0
        try:
            code = pair.wait_master(timeout_s=max(60.0, BUDGET_S - up_s))
        except subprocess.TimeoutExpired:
            pytest.fail(f"the master did not finish {BUDGET_S:g} s after the start\n{logs(pair.out_dir)}")
        assert code == 0, logs(pair.out_dir)
    codes = pair.stop()
    print(
        f"four-node session of {CYCLES} cycles on {vcan_channel}: modules up and controllers started after "
        f"{up_s:.1f} s, done after {time.monotonic() - t0:.1f} s; master's result {pair.result}"
    )
    assert codes == {"master": 0, "slave": 0, "io-master": 0, "io-slave": 0}, (codes, logs(pair.out_dir))
    # no cycle waited out its inputs, and no module lost its controller (output error state, PRE-OPERATIONAL)
    assert pair.result is not None and pair.result.lockstep_timeouts == 0, pair.result
    for side in ("master", "slave"):
        assert "lost" not in (pair.out_dir / f"io-{side}.log").read_text(), logs(pair.out_dir)
    time.sleep(0.5)  # candump shows nothing until it stops: time to read the last frames
    frames = dump.stop()
    # candump: every cycle one SYNC, each module's two input TPDOs, each controller's drive RPDO
    count = {
        cob: sum(1 for i, _ in frames if i == cob) for cob in (0x80, 0x183, 0x283, 0x184, 0x284, 0x203, 0x204)
    }
    assert count[0x80] == CYCLES, count
    assert all(n >= CYCLES for n in count.values()), count
    # the modules' heartbeats (boot-up 0, then PRE-OPERATIONAL 0x7F and OPERATIONAL 0x05)
    for hb in (0x703, 0x704):
        states = {d[0] for i, d in frames if i == hb}
        assert {0x00, 0x05} <= states, (hex(hb), states)
    # every cycle's inputs reached the controllers (no NaN sample), and the modules' truth fills the rows
    rec = merge_recordings(pair.out_dir / "master.csv", pair.out_dir / "slave.csv", scene=SCENE)
    assert len(rec) == CYCLES
    for col in ("m_T_sensor_C", "m_Q_W", "m_T_sink_C", "s_T_sensor_C", "s_Q_W", "s_T_sink_C"):
        assert np.all(np.isfinite(rec.col(col))), col
    assert fill_truth(rec, pair.modules["master"].truth_path) == CYCLES
    assert fill_truth(rec, pair.modules["slave"].truth_path) == CYCLES
    assert np.all(np.isfinite(rec.col("m_true_finger_C")))
