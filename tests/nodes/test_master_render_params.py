"""The master program renders the settings of its object dictionary (0x2600..0x2604): driven from this
test process with canopen's RemoteNode (SDO) and raw frames (NMT, SYNC) over the hub; what the
controller asked for in every cycle is read back from the node's own recording.

Without a render scene the master renders the OD's material (``telethermo mode render MATERIAL``
writes it); on a render scene the OD shows the scene script's settings in force, a written pad β
(``telethermo calibrate-finger --apply``) applies to the script's touches, and a written material
takes over from the script. Every write is taken at the next SYNC."""

from __future__ import annotations

import dataclasses
import struct
import subprocess
import threading
from pathlib import Path

import can
import canopen
import pytest

from telethermo.bus_config import path as bus_config_path
from telethermo.nodes.launch import node_command, stop_process, wait_for
from telethermo.control.core import RenderSettings
from telethermo.control.rendering import load_render_table
from telethermo.recording.format import read_recording_csv
from telethermo.transport.hub import HubThread

pytestmark = pytest.mark.slow  # starts processes

SCENES = Path(__file__).resolve().parents[2] / "sim" / "scenes"
MASTER = 1


def f32(x: float) -> float:
    return struct.unpack("<f", struct.pack("<f", x))[0]


class Frames(can.Listener):
    def __init__(self) -> None:
        self.frames: list[tuple[int, bytes]] = []
        self.lock = threading.Lock()

    def on_message_received(self, msg: can.Message) -> None:
        with self.lock:
            self.frames.append((msg.arbitration_id, bytes(msg.data)))

    def seen(self, cob: int, data: bytes) -> bool:
        with self.lock:
            return (cob, data) in self.frames


@pytest.fixture
def master(tmp_path):
    """Start the master program (SYNC consumer, RENDER) on a scene; yields a driver."""
    procs = []
    with HubThread() as hub:
        net = canopen.Network(
            can.Bus(
                interface="socketcand", host="127.0.0.1", port=hub.port, channel="telethermo", tcp_tune=True
            )
        )
        net.connect()
        frames = Frames()
        net.notifier.add_listener(frames)
        remote = canopen.RemoteNode(MASTER, str(bus_config_path("master.eds")))
        net.add_node(remote)

        class Driver:
            record = tmp_path / "master.csv"
            sdo = remote.sdo
            n = 0

            def start(self, scene: str) -> None:
                proc = subprocess.Popen(
                    node_command(
                        "master",
                        "--bus",
                        f"socketcand://127.0.0.1:{hub.port}/telethermo",
                        "--scene",
                        str(SCENES / scene),
                        "--no-sync",
                        "--mode",
                        "render",
                        "--record",
                        str(self.record),
                        "--log",
                        str(tmp_path / "m.log"),
                    ),
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.PIPE,
                )
                procs.append(proc)
                assert wait_for(lambda: frames.seen(0x701, b"\x00"), 60), "no boot-up"

            def operational(self) -> None:
                net.send_message(0, bytes([0x01, MASTER]))
                assert wait_for(lambda: frames.seen(0x701, b"\x05"), 10)

            def syncs(self, k: int) -> None:
                for _ in range(k):
                    self.n += 1
                    net.send_message(0x80, bytes([self.n % 240 + 1]))
                remote.sdo.upload(0x1000, 0)  # SDO round trip: every SYNC before it was handled (ordered bus)

            def recording(self):
                code = stop_process(procs[-1])
                assert code == 0, procs[-1].stderr.read().decode()
                return read_recording_csv(self.record)

        try:
            yield Driver()
        finally:
            for p in procs:
                stop_process(p)
            net.disconnect()


def targets(rs: RenderSettings) -> tuple[float, float]:
    """What RENDER asks for with ``rs``: T_pad0 before the detected contact (eq. 7), T_contact after (eq.
    1)."""
    return rs.T_pad0_C, rs.T_contact_C


def od_render(sdo) -> dict[str, float]:
    return {
        k: sdo[k].raw for k in ("material_code", "material_beta", "object_T0_C", "finger_T0_C", "pad_beta")
    }


def test_the_master_renders_the_material_written_into_its_od(master):
    master.start("probe_touches_al_steel_wood.toml")  # no render script: the OD's settings are rendered
    sdo = master.sdo
    defaults = {f.name: f.default for f in dataclasses.fields(RenderSettings)}
    od = od_render(sdo)
    assert od["pad_beta"] == f32(defaults["beta_pad"]) and od["finger_T0_C"] == f32(defaults["T_finger0_C"])
    assert sdo["mode"].raw == 2
    before = RenderSettings(
        beta_object=od["material_beta"],
        T_object0_C=od["object_T0_C"],
        beta_pad=defaults["beta_pad"],
        T_finger0_C=defaults["T_finger0_C"],
    )
    master.operational()
    master.syncs(20)
    table = load_render_table()
    code = list(table).index("wood") + 1  # material_code k: the table's k-th entry
    sdo["material_code"].raw = code
    sdo["object_T0_C"].raw = 20.0
    sdo["finger_T0_C"].raw = 34.5
    sdo["pad_beta"].raw = 3.1
    assert sdo["material_beta"].raw == od["material_beta"]  # taken at the next SYNC, not before
    master.syncs(20)
    assert sdo["material_beta"].raw == f32(table["wood"]) and sdo["material_code"].raw == code
    sdo["material_beta"].raw = 7.5  # a custom β: the code goes to 0
    master.syncs(20)
    assert sdo["material_code"].raw == 0
    rec = master.recording()
    target = rec.col("m_target_C")
    assert len(target) == 60
    after = RenderSettings(beta_object=table["wood"], T_object0_C=20.0, beta_pad=f32(3.1), T_finger0_C=34.5)
    custom = dataclasses.replace(after, beta_object=7.5)
    for rows, rs, tol in (
        (range(0, 20), before, 1e-9),
        (range(20, 40), after, 1e-9),
        (range(40, 60), custom, 1e-9),
    ):
        want = targets(rs)
        for k in rows:
            assert min(abs(target[k] - w) for w in want) <= tol, (k, target[k], want)
    assert min(abs(a - b) for a in targets(before) for b in targets(after)) > 0.5  # the three really differ
    assert min(abs(a - b) for a in targets(after) for b in targets(custom)) > 0.5


def test_on_a_render_scene_the_od_shows_the_script_and_a_written_pad_beta_applies_to_it(master):
    from telethermo import sim
    from telethermo.offline.render_script import RenderScript

    scene = "virtual_materials.toml"
    first = RenderScript(sim.load_scene(SCENES / scene)).first
    table = load_render_table()
    master.start(scene)
    sdo = master.sdo
    assert od_render(sdo) == {
        "material_code": list(table).index(first.material) + 1,
        "material_beta": f32(first.beta_object),
        "object_T0_C": f32(first.T_object0_C),
        "finger_T0_C": f32(first.T_finger0_C),
        "pad_beta": f32(first.beta_pad),
    }
    master.operational()
    master.syncs(10)
    sdo["pad_beta"].raw = 3.0  # calibrate-finger --apply
    master.syncs(10)
    assert sdo["pad_beta"].raw == 3.0 and sdo["material_code"].raw == list(table).index(first.material) + 1
    sdo["material_code"].raw = list(table).index("brass") + 1  # the operator takes over from the script
    master.syncs(10)
    rec = master.recording()
    target = rec.col("m_target_C")
    calibrated = dataclasses.replace(first, beta_pad=3.0)
    brass = dataclasses.replace(calibrated, beta_object=table["brass"], material="brass")
    assert list(target[:10]) == [first.T_pad0_C] * 10  # no touch before 5 s: the pre-set of eq. 7
    assert list(target[10:20]) == [calibrated.T_pad0_C] * 10
    assert list(target[20:30]) == [brass.T_pad0_C] * 10
    assert len({first.T_pad0_C, calibrated.T_pad0_C, brass.T_pad0_C}) == 3


def test_the_later_phase_objects_show_the_script_object_and_take_writes(master):
    """0x2605..0x2607: the script's object (eps, 20 mm, adiabatic back, conduction model) is shown; a written
    model and thickness are taken at the next SYNC; RC/conduction with a custom β (no material) is refused."""
    master.start("virtual_materials.toml")
    sdo = master.sdo
    assert [sdo[k].raw for k in ("later_model", "object_thickness_mm", "object_back")] == [2, 20.0, 0]
    master.operational()
    master.syncs(5)
    sdo["later_model"].raw = 1
    sdo["object_thickness_mm"].raw = 1.0
    master.syncs(5)
    assert [sdo[k].raw for k in ("later_model", "object_thickness_mm", "object_back")] == [1, 1.0, 0]
    with pytest.raises(canopen.SdoAbortedError):  # a custom β has no material for the RC model
        sdo["material_beta"].raw = 7.5
    sdo["later_model"].raw = 0
    master.syncs(2)
    sdo["material_beta"].raw = 7.5  # semi-infinite: any β
    master.syncs(2)
    with pytest.raises(canopen.SdoAbortedError):
        sdo["later_model"].raw = 1
    assert master.recording().col("m_target_C").size == 14
