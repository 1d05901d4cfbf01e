"""Bus loss and return over the hub (issue 12): kill the hub (SIGKILL) under a running telepresence pair;
both nodes go safe (peer trip within a cycle or two of the loss, ramp to neutral, cut); restart the hub on
the same port: both nodes reopen their bus by themselves, their peer trips are cleared and the session
goes on. Observed from the node recordings and by an independent canopen client (RemoteNode from the
shipped EDS files) on the restarted hub."""

from __future__ import annotations

from pathlib import Path

import can
import canopen
import numpy as np
import pytest

from telethermo.bus_config import path as bus_config_path
from telethermo.nodes.launch import HubProcess, NodePair, PairConfig, wait_for
from telethermo.transport.hub import HubConfig, HubThread
from telethermo.recording.format import read_recording_csv

pytestmark = pytest.mark.slow  # starts processes

SCENE = Path(__file__).resolve().parents[2] / "sim" / "scenes" / "probe_touches_al_steel_wood.toml"
EMCY_BUS_BACK = 0x8140


def _log(pair: NodePair, role: str) -> str:
    p = pair.log(role)
    return p.read_text() if p.exists() else ""


def _client(port: int) -> tuple[canopen.Network, dict[str, canopen.RemoteNode]]:
    net = canopen.Network(
        can.Bus(interface="socketcand", host="127.0.0.1", port=port, channel="telethermo", tcp_tune=True)
    )
    net.connect()
    nodes = {}
    for role, node_id in (("master", 1), ("slave", 2)):
        nodes[role] = canopen.RemoteNode(node_id, str(bus_config_path(f"{role}.eds")))
        net.add_node(nodes[role])
        nodes[role].sdo.RESPONSE_TIMEOUT = 2.0
    return net, nodes


def _lost_at(rec, prefix: str) -> int:
    """The first row whose new trips include peer_lost."""
    return next(k for k, t in enumerate(rec.text(f"{prefix}_new_trips")) if "peer_lost" in t)


def test_hub_killed_and_restarted_the_pair_goes_safe_and_resumes_by_itself(tmp_path):
    pair = NodePair(PairConfig(scene=SCENE, out_dir=tmp_path, cycles=0, seed=0, progress_every=10))
    pair.start()
    net = None
    try:
        # before the probe's first touch (1.0 s): no material identified yet, so the master's graceful
        # link-loss
        # rendering (issue 15) does not apply and the loss must trip at once
        assert wait_for(lambda: pair.progress[0] >= 60, 120), "session did not start"
        port = pair.hub.port
        pair.hub.proc.kill()  # SIGKILL: every TCP stream ends at once
        pair.hub.proc.wait()
        for role in ("master", "slave"):
            assert wait_for(lambda: "bus lost" in _log(pair, role), 30), f"{role} did not notice the loss"
            assert wait_for(lambda: "-> CUT" in _log(pair, role), 60), f"{role} never cut its current"
        assert pair.master.poll() is None and pair.slave.poll() is None, "a node ended with its bus"

        pair.hub = HubProcess(port=port, log_path=pair.log("hub"))  # the hub comes back where it was
        pair.hub.start()
        for role in ("master", "slave"):
            assert wait_for(lambda: "bus back" in _log(pair, role), 30), f"{role} did not reopen its bus"
        assert wait_for(lambda: "peer values back: cleared peer_lost" in _log(pair, "master"), 60)
        assert wait_for(lambda: "peer values back: cleared peer_lost" in _log(pair, "slave"), 60)
        for role in (
            "master",
            "slave",
        ):  # issue 25: one line per loss on the terminal, no python-can traceback
            err = pair.log(f"{role}-stderr").read_text()
            assert "Traceback" not in err and "bus socketcand://127.0.0.1:" in err and " lost: " in err, err
        k_back = pair.progress[0]
        assert wait_for(lambda: pair.progress[0] >= k_back + 200, 120), "the session did not go on"

        net, nodes = _client(port)  # an independent client on the new hub
        for role, node in nodes.items():
            assert node.sdo["active_trips"].raw == 0, f"{role}: trips still latched"
            assert node.sdo[0x1001].raw == 0, f"{role}: error register not clear"
            history = [node.sdo[0x1003][i].raw & 0xFFFF for i in range(1, node.sdo[0x1003][0].raw + 1)]
            assert EMCY_BUS_BACK in history, f"{role}: no 'recovered from bus off' in 0x1003: {history}"
    finally:
        if net is not None:
            net.disconnect()
        codes = pair.stop()
    assert codes["master"] == 0 and codes["slave"] == 0

    for role, prefix in (("master", "m"), ("slave", "s")):
        rec = read_recording_csv(pair.recording(role))
        peer, state, cur = (
            rec.col(f"{prefix}_peer_estimate_C"),
            rec.col(f"{prefix}_safety_state"),
            rec.col(f"{prefix}_current_A"),
        )
        k_trip = _lost_at(rec, prefix)
        # the peer trip comes at once (not after the 10-cycle PDO miss limit): bus loss is peer loss
        fresh = np.flatnonzero(np.diff(peer[: k_trip + 1]) != 0) + 1
        assert k_trip - fresh[-1] <= 3, f"{role}: trip {k_trip - fresh[-1]} cycles after the last peer PDO"
        k_resume = k_trip + next(i for i, s in enumerate(state[k_trip:]) if s < 2)
        lost = slice(k_trip, k_resume)
        assert np.all(state[lost] >= 2), f"{role}: not safe throughout the outage"
        cut = np.flatnonzero(state[lost] == 3)
        assert cut.size and np.all(cur[k_trip + cut[0] : k_resume] == 0.0), f"{role}: current not cut"
        after = slice(k_resume, len(rec))
        assert np.all(state[after] < 2), f"{role}: tripped again after the return"
        assert np.count_nonzero(np.diff(peer[after])) > 0.9 * (len(rec) - k_resume - 1), f"{role}: peer stale"
    slave_sync = read_recording_csv(pair.recording("slave")).col("sync_cycle")
    assert np.any(slave_sync == -1), "the slave ran no local fallback cycle while its bus was away"


def _lockstep_timeouts(log_text: str) -> int:
    line = next(l for l in log_text.splitlines() if "stopped (" in l and "lockstep timeouts" in l)
    return int(line.split(" late, ")[1].split(" lockstep")[0])


def test_a_short_outage_does_not_leave_lockstep_waiting_for_a_sync_the_slave_never_saw(tmp_path):
    """The hub gone for a few milliseconds (a new one on the same port at once, in this process): shorter
    than the heartbeat consumer time, so neither node need see the other lost, and the two reopen at
    different times. The session goes on with few lockstep timeouts. (A SYNC the master sends before the slave
    is back is never answered, and lockstep then waited its patience bound on every later cycle, for good:
    seen
    in the vcan VM, tests/vcan/test_vcan_bus_loss.py; on this fast host the two reopen too close together for
    it to happen reliably, so this test guards the quick-outage path, not that race.)"""
    pair = NodePair(PairConfig(scene=SCENE, out_dir=tmp_path, cycles=0, seed=0, progress_every=10))
    pair.start()
    hub = None
    try:
        assert wait_for(lambda: pair.progress[0] >= 150, 120), "session did not start"
        port = pair.hub.port
        pair.hub.proc.kill()
        pair.hub.proc.wait()
        pair.hub = None
        for i in range(5):
            if hub is not None:
                hub.__exit__(None, None, None)  # closes every client's stream, as a killed hub
            hub = HubThread(HubConfig(port=port, idle_timeout_s=0)).__enter__()
            for role in ("master", "slave"):
                assert wait_for(lambda: _log(pair, role).count("bus back") > i, 30), f"{role} not back"
            k = pair.progress[0]
            assert wait_for(lambda: pair.progress[0] >= k + 100, 120), "the session did not go on"
    finally:
        codes = pair.stop()
        if hub is not None:
            hub.__exit__(None, None, None)
    assert codes["master"] == 0
    timeouts = _lockstep_timeouts(_log(pair, "master"))
    assert timeouts <= 2 * 5, f"{timeouts} lockstep timeouts after 5 outages"
