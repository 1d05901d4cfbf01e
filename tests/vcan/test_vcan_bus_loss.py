"""Bus loss and return on SocketCAN (issue 12): ``ip link set vcan0 down`` under a running pair; both nodes
notice (ENETDOWN, the interface's state), trip peer_lost, cut and keep retrying; ``ip link set vcan0 up``:
both reopen their socket by themselves, their peer trips are cleared and the session goes on.

Needs root (the VM of ../shared/tools/vcan-run runs the tests as root); no timing is asserted."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

from telethermo.nodes.launch import NodePair, PairConfig, wait_for
from telethermo.recording.format import read_recording_csv

pytestmark = [pytest.mark.vcan, pytest.mark.slow]

SCENE = Path(__file__).resolve().parents[2] / "sim" / "scenes" / "probe_touches_al_steel_wood.toml"


def _ip_link(channel: str, state: str) -> None:
    subprocess.run(["ip", "link", "set", channel, state], check=True, capture_output=True, timeout=30)


def _log(pair: NodePair, role: str) -> str:
    p = pair.log(role)
    return p.read_text() if p.exists() else ""


def test_interface_down_then_up_the_pair_goes_safe_and_resumes_by_itself(
    vcan_channel, slow_network, tmp_path
):
    if os.geteuid() != 0:
        pytest.skip("needs root to set the interface down and up (run inside ../shared/tools/vcan-run)")
    pair = NodePair(
        PairConfig(
            scene=SCENE,
            out_dir=tmp_path,
            bus=f"socketcan:{vcan_channel}",
            cycles=0,
            seed=0,
            network=slow_network,
            progress_every=10,
            master_args=["--wait-peer", "300"],
        )
    )
    try:
        pair.start()
        assert wait_for(lambda: pair.progress[0] >= 100, 600), "session did not start"
        _ip_link(vcan_channel, "down")
        try:
            for role in ("master", "slave"):
                assert wait_for(lambda: "bus lost" in _log(pair, role), 120), (
                    f"{role} did not notice the loss"
                )
                assert wait_for(lambda: "-> CUT" in _log(pair, role), 300), f"{role} never cut its current"
            assert pair.master.poll() is None and pair.slave.poll() is None, "a node ended with its bus"
        finally:
            _ip_link(vcan_channel, "up")
        for role in ("master", "slave"):
            assert wait_for(lambda: "bus back" in _log(pair, role), 120), f"{role} did not reopen its bus"
            assert wait_for(lambda: "peer values back: cleared peer_lost" in _log(pair, role), 300), (
                f"{role} did not resume:\n{_log(pair, role)[-3000:]}"
            )
        k_back = pair.progress[0]
        assert wait_for(lambda: pair.progress[0] >= k_back + 300, 600), "the session did not go on"
    finally:
        codes = pair.stop()
    assert codes == {"master": 0, "slave": 0}
    for role, prefix in (("master", "m"), ("slave", "s")):
        rec = read_recording_csv(pair.recording(role))
        state = rec.col(f"{prefix}_safety_state")
        k_trip = next(k for k, t in enumerate(rec.text(f"{prefix}_new_trips")) if "peer_lost" in t)
        k_resume = k_trip + next(i for i, s in enumerate(state[k_trip:]) if s < 2)
        assert np.all(state[k_trip:k_resume] >= 2) and np.any(state[k_trip:k_resume] == 3), role
        # after the return the pair runs normally: in the emulated VM one run of three (2026-11-26) saw the
        # slave's peer values miss once more for a few cycles right after the return (a second peer_lost ramp
        # that cleared by itself), and the stop at the end can start one too; what must hold is a stretch of
        # at least 100 normal cycles after the return (the test waits for 300 more cycles of progress)
        normal = np.concatenate([[0], (state[k_resume:] < 2).astype(int), [0]])
        edges = np.flatnonzero(np.diff(normal))
        longest = int(np.max(edges[1::2] - edges[::2])) if edges.size else 0
        assert longest >= 100, f"{role}: no 100 normal cycles after the return (longest {longest})"
