"""The node runtime in the test process, on python-can's ``virtual`` bus (a real python-can bus, no mock),
observed by canopen's own client: ``RemoteNode`` (with its ``NmtMaster``, SDO client, PDO maps and EMCY
consumer) built from the shipped EDS files. The same facts the process tests check (boot-up, NMT start,
SDO, a lockstep cycle's TPDOs after SYNC, peer loss), in seconds.
"""

from __future__ import annotations

import threading
import uuid
from pathlib import Path

import canopen
import numpy as np
import pytest

from telethermo.nodes.launch import wait_for
from telethermo.nodes.options import NodeOptions
from telethermo.nodes.parts import build_parts
from telethermo.nodes.runtime import NodeRuntime
from telethermo.device.device import NmtState
from telethermo.device.netconfig import load_network
from telethermo.control.safety import EMCY_CODES, Trip
from telethermo.control.types import Mode, Role
from telethermo.ident.modelfile import default_model_path
from telethermo.ident.odmodel import CMD_UNLOAD, STATUS_LOADED, STATUS_NONE
from telethermo.transport.bus import TransportSettings

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "sim" / "scenes" / "probe_touches_al_steel_wood.toml"
EDS = {Role.MASTER: ROOT / "bus_config" / "master.eds", Role.SLAVE: ROOT / "bus_config" / "slave.eds"}
SYNC_COB = 0x80
NET = load_network()
ID = {role: NET.node(role.value).node_id for role in Role}


class Bench:
    """Node runtimes and one canopen client on a fresh virtual channel; everything closed at the end."""

    def __init__(self) -> None:
        self.channel = f"inproc-{uuid.uuid4().hex[:8]}"
        self.client = canopen.Network()
        self.client.connect(interface="virtual", channel=self.channel)
        self.frames: list[tuple[int, bytes]] = []
        self._frames_lock = threading.Lock()
        self.runtimes: list[NodeRuntime] = []

    def remote(self, role: Role) -> canopen.RemoteNode:
        """canopen's client view of a node, from the shipped EDS."""
        node = canopen.RemoteNode(ID[role], str(EDS[role]))
        self.client.add_node(node)
        return node

    def watch(self, *cob_ids: int) -> None:
        """Keep every frame of ``cob_ids`` the client receives, in order."""
        for cob in cob_ids:
            self.client.subscribe(cob, self._keep)

    def _keep(self, can_id: int, data: bytearray, timestamp: float) -> None:
        with self._frames_lock:
            self.frames.append((can_id, bytes(data)))

    def sequence(self) -> list[int]:
        with self._frames_lock:
            return [cob for cob, _ in self.frames]

    def node(self, role: Role, *, start: bool = True, model: Path | None = None) -> NodeRuntime:
        """A node runtime as ``telethermo-master``/``-slave`` builds it (lockstep, simulated rig of SCENE)."""
        producer = role is Role.MASTER
        opts = NodeOptions(role=role, scene=SCENE, timing="lockstep", produce_sync=producer, model=model)
        parts = build_parts(opts, period_s=NET.sync.period_s)
        rt = NodeRuntime(
            role,
            ID[role],
            NET,
            TransportSettings("virtual", self.channel),
            parts,
            mode=Mode.TELEPRESENCE,
            lockstep=True,
            produce_sync=producer,
            record_timing=False,
        )
        self.runtimes.append(rt)
        if start:
            rt.start()
        return rt

    def close(self) -> None:
        for rt in reversed(self.runtimes):
            rt.stop("test end")
        self.client.disconnect()


@pytest.fixture
def bench():
    b = Bench()
    yield b
    b.close()


def test_boot_up_nmt_start_and_sdo_read(bench):
    node = bench.remote(Role.MASTER)
    states: list[int] = []
    node.nmt.add_heartbeat_callback(states.append)
    rt = bench.node(Role.MASTER)
    assert wait_for(lambda: 0 in states, 5), "no boot-up message"  # boot-up: 0x701 [0x00]
    assert wait_for(lambda: states and states[-1] == 127, 5)  # then PRE-OPERATIONAL heartbeats
    assert node.nmt.state == "PRE-OPERATIONAL"
    assert rt.device.state is NmtState.PRE_OPERATIONAL

    node.nmt.state = "OPERATIONAL"  # NMT start from canopen's NmtMaster
    assert wait_for(lambda: rt.device.state is NmtState.OPERATIONAL, 5)
    assert wait_for(lambda: node.nmt.state == "OPERATIONAL", 5), "the heartbeat does not report OPERATIONAL"

    assert node.sdo[0x1017].raw == NET.heartbeat.producer_ms  # heartbeat producer time, ms
    assert node.sdo[0x1016][1].raw == (ID[Role.SLAVE] << 16) | NET.heartbeat.consumer_ms  # watches its peer
    assert node.sdo["neutral_C"].raw == pytest.approx(32.0)  # the controller's parameter, °C
    assert node.sdo[0x2704].raw is True  # lockstep flag
    assert node.sdo["mode"].raw == int(Mode.TELEPRESENCE)


def test_lockstep_cycles_send_both_tpdo1_after_each_sync(bench):
    slave = bench.node(Role.SLAVE)
    master = bench.node(Role.MASTER)
    node_m = bench.remote(Role.MASTER)
    node_m.tpdo.read()  # the TPDO1 mapping, by SDO
    tpdo1_m = node_m.tpdo[1]
    assert tpdo1_m.cob_id == 0x180 + ID[Role.MASTER] and tpdo1_m.enabled
    tpdo1_s_cob = 0x180 + ID[Role.SLAVE]
    bench.watch(SYNC_COB, tpdo1_m.cob_id, tpdo1_s_cob)
    assert master.wait_for_peer(10.0), "the slave's heartbeat was not seen"

    n = 6
    assert master.run_producer(n) == n
    assert master.stats.cycles == n and slave.stats.cycles == n
    assert master.stats.lockstep_timeouts == 0
    # the watching client's own notifier thread may still be handing over the last frames
    assert wait_for(
        lambda: (
            bench.sequence().count(SYNC_COB) == n
            and bench.sequence().count(tpdo1_m.cob_id) == n
            and bench.sequence().count(tpdo1_s_cob) == n
        ),
        5,
    )
    seq = bench.sequence()
    assert seq.count(SYNC_COB) == n
    syncs = [i for i, cob in enumerate(seq) if cob == SYNC_COB] + [len(seq)]
    for k in range(n):  # lockstep: both nodes' TPDO1 of SYNC k arrive before SYNC k+1
        between = seq[syncs[k] + 1 : syncs[k + 1]]
        assert between.count(tpdo1_m.cob_id) == 1 and between.count(tpdo1_s_cob) == 1, (k, between)
    # canopen's decoding of the last TPDO1 by the EDS mapping: the estimate the master's OD holds (REAL32)
    assert tpdo1_m["estimate_C"].raw == pytest.approx(float(np.float32(master.device.read("estimate_C"))))
    assert 20.0 < tpdo1_m["estimate_C"].raw < 45.0
    assert master.sync_cycle == slave.sync_cycle == n - 1


def test_peer_loss_trips_the_master_and_its_return_resumes(bench):
    node_m = bench.remote(Role.MASTER)
    slave = bench.node(Role.SLAVE)
    master = bench.node(Role.MASTER)
    assert master.wait_for_peer(10.0)
    run = threading.Thread(target=master.run_producer, args=(0,), daemon=True)
    run.start()
    try:
        assert wait_for(lambda: master.stats.cycles >= 30, 20)
        assert not master.cycle.state.env.trips
        slave.stop("killed")  # its heartbeat and PDOs stop
        lost = EMCY_CODES[Trip.PEER_LOST]
        assert wait_for(lambda: any(e.code == lost for e in node_m.emcy.log), 10), "no EMCY 0x8130"
        # the heartbeat consumer's EMCY can come before the cycle that latches the trip: wait for that cycle
        assert wait_for(lambda: Trip.PEER_LOST in master.cycle.state.env.trips, 5)
        assert wait_for(lambda: node_m.sdo["active_trips"].raw != 0, 5)

        bench.node(Role.SLAVE)  # the slave boots again
        assert wait_for(lambda: master.stats.peer_resumes == 1, 20), "the master did not resume"
        assert wait_for(lambda: any(e.code == 0x0000 for e in node_m.emcy.log), 5), "no error-reset EMCY"
        assert wait_for(lambda: not master.cycle.state.env.trips, 5)
        assert master.stats.nmt_starts_sent >= 1  # it started the rebooted slave
    finally:
        master.stop_event.set()
        run.join(10)
    assert not run.is_alive()


def test_sdo_writes_reach_the_parameters_the_model_and_the_identification_service(bench):
    node = bench.remote(Role.MASTER)
    rt = bench.node(Role.MASTER, model=default_model_path())
    assert node.sdo["model_status"].raw == STATUS_LOADED and node.sdo["model_crc32"].raw != 0
    with pytest.raises(canopen.SdoAbortedError) as exc:
        node.sdo["ident_fetch_sample"].raw = 0  # no experiment recorded yet
    assert exc.value.code == 0x08000024
    with pytest.raises(canopen.SdoAbortedError) as exc:
        node.sdo["T_max_C"].raw = 60.0  # above the EDS limit (43 °C)
    assert exc.value.code == 0x06090031
    kp0 = rt.settings.params.kp_A_per_C
    node.sdo["kp_A_per_C"].raw = kp0 + 0.25  # into the book now, into the controller at SYNC
    node.sdo["model_command"].raw = CMD_UNLOAD  # the flux estimator needs no model
    assert rt.settings.params.kp_A_per_C == kp0 and rt.model is not None
    assert node.sdo["model_command"].raw == 0  # a command: reads 0
    assert rt.run_producer(2) == 2
    assert rt.settings.params.kp_A_per_C == pytest.approx(kp0 + 0.25)
    assert node.sdo["kp_A_per_C"].raw == pytest.approx(kp0 + 0.25)
    assert rt.model is None and rt.models_loaded == 1
    assert node.sdo["model_status"].raw == STATUS_NONE and node.sdo["model_crc32"].raw == 0


def test_an_identification_experiment_is_recorded_and_fetched_sample_by_sample(bench):
    """IDENTIFY with a short plan set by SDO: the progress objects (0x2807..0x280A) and, per sample, the
    fetched objects (0x280C..0x280E) as canopen's SDO client reads them: the record's columns are the
    sensor temperature, the commanded current (the plan's, as the guard never acted) and the flux."""
    node = bench.remote(Role.MASTER)
    rt = bench.node(Role.MASTER)
    plan = {"ident_rest_samples": 2, "ident_train_samples": 5, "ident_validation_samples": 3}
    for name, value in {**plan, "ident_hold_samples": 1}.items():
        node.sdo[name].raw = value
    node.sdo["mode"].raw = int(Mode.IDENTIFY)  # into the controller at the next SYNC
    total = sum(plan.values())
    assert rt.run_producer(total + 2) == total + 2
    assert node.sdo["ident_state"].raw == 2  # done
    assert node.sdo["ident_sample"].raw > total and node.sdo["ident_guard"].raw == 0
    assert node.sdo["ident_start_cycle"].raw == 0  # no cycle before: the mode came in at the first SYNC
    identify = rt.settings.params.identify
    assert identify.total == total
    rows = []
    for j in range(total):
        node.sdo["ident_fetch_sample"].raw = j
        rows.append([node.sdo[n].raw for n in ("ident_fetched_T_sensor_C", "ident_fetched_current_A")])
        rows[-1].append(node.sdo["ident_fetched_Q_W"].raw)
    got = np.array(rows)
    assert np.array_equal(got, rt.ident.record.astype(float))  # REAL32 both ways: exact
    assert np.array_equal(got[:, 1], identify.currents().astype(np.float32).astype(float))
    assert np.all((got[:, 0] > 15.0) & (got[:, 0] < 45.0)) and np.any(got[:, 1] != 0.0)
    with pytest.raises(canopen.SdoAbortedError) as exc:
        node.sdo["ident_fetch_sample"].raw = total  # beyond the record
    assert exc.value.code == 0x08000024
