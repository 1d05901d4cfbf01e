"""The slave node program alone, driven from this test process as NMT master and SYNC producer with
canopen's own client (RemoteNode SDO, raw frames): NMT states gate the PDOs, SDO works where it
must, reset gives a boot-up, malformed traffic is counted and ignored, NaN in a PDO trips the
envelope (EMCY) and never reaches the current."""

from __future__ import annotations

import math
import struct
import subprocess
import threading
from pathlib import Path

import can
import canopen
import pytest

from telethermo.bus_config import path as bus_config_path
from telethermo.nodes.launch import node_command, stop_process, wait_for
from telethermo.transport.hub import HubThread

pytestmark = pytest.mark.slow  # starts processes

SCENE = Path(__file__).resolve().parents[2] / "sim" / "scenes" / "probe_touches_al_steel_wood.toml"
SLAVE = 2


class Frames(can.Listener):
    def __init__(self) -> None:
        self.frames: list[tuple[int, bytes]] = []
        self.lock = threading.Lock()

    def on_message_received(self, msg: can.Message) -> None:
        with self.lock:
            self.frames.append((msg.arbitration_id, bytes(msg.data)))

    def mark(self) -> int:
        with self.lock:
            return len(self.frames)

    def since(self, mark: int, cob: int | None = None) -> list[tuple[int, bytes]]:
        with self.lock:
            return [(c, d) for c, d in self.frames[mark:] if cob is None or c == cob]


def ambient_start_scene(tmp_path: Path) -> Path:
    """The probe scene with the probe starting at ambient (25 °C, 0 A) instead of settled at the finger's
    temperature: the protocol checks below count on a probe that sits well below the neutral temperature."""
    text = SCENE.read_text(encoding="utf-8")
    start = text.index("[slave]\n")
    end = text.index("[[slave.contacts]]")
    p = tmp_path / "probe_ambient_start.toml"
    p.write_text(text[:start] + text[end:], encoding="utf-8")
    return p


@pytest.fixture
def slave(tmp_path):
    scene = ambient_start_scene(tmp_path)
    with HubThread() as hub:
        bus_text = f"socketcand://127.0.0.1:{hub.port}/telethermo"
        net = canopen.Network(
            can.Bus(
                interface="socketcand", host="127.0.0.1", port=hub.port, channel="telethermo", tcp_tune=True
            )
        )
        net.connect()
        frames = Frames()
        net.notifier.add_listener(frames)
        proc = subprocess.Popen(
            node_command(
                "slave",
                "--bus",
                bus_text,
                "--scene",
                str(scene),
                "--log",
                str(tmp_path / "slave.log"),
                "--store",  # its own parameter store: never the per-user one
                str(tmp_path / "slave-store.json"),
            ),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
        )
        remote = canopen.RemoteNode(SLAVE, str(bus_config_path("slave.eds")))
        net.add_node(remote)
        try:
            assert wait_for(lambda: (0x702, b"\x00") in frames.since(0), 60), "no boot-up"
            yield net, remote, frames, proc
        finally:
            code = stop_process(proc)
            net.disconnect()
            assert code == 0, proc.stderr.read().decode()


def sync(net, counter=1):
    net.send_message(0x80, bytes([counter]))


def sdo_fence(remote) -> None:
    """An SDO round trip: every frame the slave sent for what we sent before is now in (ordered bus)."""
    remote.sdo.upload(0x1000, 0)


def reaches_state(frames, mark, state: int) -> bool:
    """A heartbeat of the slave with NMT ``state`` arrives after ``mark`` (one sent just before the
    command may still report the old state)."""
    return wait_for(lambda: (0x702, bytes([state])) in frames.since(mark, 0x702), 10)


def test_nmt_gates_pdos_and_sdo(slave):
    net, remote, frames, _ = slave
    # PRE-OPERATIONAL after boot: SDO works, SYNC gives no PDO
    assert remote.sdo["mode"].raw == 1  # telepresence (the program's default)
    m = frames.mark()
    sync(net)
    sdo_fence(remote)
    assert not frames.since(m, 0x182)
    # OPERATIONAL: TPDO1 on every SYNC
    m0 = frames.mark()
    net.send_message(0, bytes([0x01, SLAVE]))
    assert reaches_state(frames, m0, 5)
    m = frames.mark()
    for c in range(1, 4):
        sync(net, c)
    sdo_fence(remote)
    tpdos = frames.since(m, 0x182)
    assert len(tpdos) == 3 and all(len(d) == 8 for _, d in tpdos)
    assert remote.sdo["cycle_counter"].raw == 3
    # STOPPED: no PDO and no SDO; NMT still obeyed
    m0 = frames.mark()
    net.send_message(0, bytes([0x02, SLAVE]))
    assert reaches_state(frames, m0, 4)
    m = m0 = frames.mark()
    sync(net, 4)
    net.send_message(0, bytes([0x80, SLAVE]))  # enter pre-operational
    sdo_fence(remote)  # answered in PRE-OPERATIONAL only
    assert not frames.since(m, 0x182)
    assert reaches_state(frames, m0, 127)
    # PRE-OPERATIONAL: SDO read and write (range-checked), no PDO
    remote.sdo["mode"].raw = 0
    assert remote.sdo["mode"].raw == 0
    with pytest.raises(canopen.SdoAbortedError) as info:
        remote.sdo["mode"].raw = 9
    assert info.value.code in (0x06090030, 0x06090031)
    m = frames.mark()
    sync(net, 5)
    sdo_fence(remote)
    assert not frames.since(m, 0x182)
    assert remote.sdo["cycle_counter"].raw == 3  # no control cycle ran outside OPERATIONAL
    # reset node: boot-up, then PRE-OPERATIONAL heartbeats, objects back to their power-on values
    m = frames.mark()
    net.send_message(0, bytes([0x81, SLAVE]))
    assert wait_for(lambda: (0x702, b"\x00") in frames.since(m), 10)
    boot = m + frames.since(m).index((0x702, b"\x00"))
    assert reaches_state(frames, boot + 1, 127)
    assert remote.sdo["mode"].raw == 1  # the program's power-on mode again (was set to 0 above)
    assert remote.sdo["cycle_counter"].raw == 0


def test_malformed_traffic_is_counted_and_ignored(slave):
    net, remote, frames, _ = slave
    m0 = frames.mark()
    net.send_message(0, bytes([0x01, SLAVE]))
    assert reaches_state(frames, m0, 5)
    malformed0 = remote.sdo["malformed_frames"].raw
    unknown0 = remote.sdo["unknown_cobid_frames"].raw
    m = frames.mark()
    net.send_message(0x181, b"\x00\x00\x80")  # RPDO1 with 3 bytes instead of 8
    net.send_message(0x80, b"\x01\x02")  # SYNC with 2 bytes
    for i in range(300):  # a burst of frames nobody on this network owns
        net.send_message(0x555, bytes([i & 0xFF]))
    net.send_message(0x1ABCDE, b"\x01")  # an extended identifier
    sync(net, 7)
    sdo_fence(remote)
    assert remote.sdo["malformed_frames"].raw - malformed0 == 2
    assert remote.sdo["unknown_cobid_frames"].raw - unknown0 == 301
    assert len(frames.since(m, 0x182)) == 1  # the node still answers the good SYNC
    emcy = [d for _, d in frames.since(m, 0x82)]
    assert any(int.from_bytes(d[:2], "little") == 0x8210 for d in emcy)  # PDO length error


def test_nan_in_a_pdo_trips_the_envelope_not_the_current(slave):
    net, remote, frames, _ = slave
    m0 = frames.mark()
    net.send_message(0, bytes([0x01, SLAVE]))
    assert reaches_state(frames, m0, 5)
    T = 28.0
    for c in range(1, 31):  # a healthy peer: RPDO1 before each SYNC
        net.send_message(0x181, struct.pack("<ff", T, 0.1))
        sync(net, c)
    sdo_fence(remote)
    assert remote.sdo["safety_state"].raw in (0, 1)
    assert remote.sdo["peer_estimate_C"].raw == pytest.approx(T)
    m = frames.mark()
    for c in range(31, 41):
        net.send_message(0x181, struct.pack("<ff", math.nan, 0.1))
        sync(net, c)
    sdo_fence(remote)
    assert math.isnan(remote.sdo["peer_estimate_C"].raw)  # the NaN reached the object dictionary ...
    emcy = [int.from_bytes(d[:2], "little") for _, d in frames.since(m, 0x82) if len(d) == 8]
    assert 0xFF02 in emcy  # ... and tripped the envelope (PEER_INVALID)
    assert 0x8210 not in emcy  # no PDO length error: the PDO was processed
    assert remote.sdo["last_trip_code"].raw == 0xFF02
    assert remote.sdo["safety_state"].raw in (2, 3)  # ramp to neutral / cut
    current = remote.sdo["current_A"].raw
    assert math.isfinite(current) and abs(current) <= 0.8 * 2.0 * 1.5
    cmd = remote.sdo["T_cmd_C"].raw
    assert math.isfinite(cmd) and 15.0 <= cmd <= 43.0
    est = [struct.unpack("<ff", d)[0] for _, d in frames.since(m, 0x182)]
    assert len(est) == 10 and all(math.isfinite(e) for e in est)


def test_mode_by_sdo_changes_the_control_and_an_impossible_mode_is_refused(slave):
    net, remote, frames, _ = slave
    m0 = frames.mark()
    net.send_message(0, bytes([0x01, SLAVE]))
    assert reaches_state(frames, m0, 5)

    def cycles(n, start, T=40.0):
        for c in range(start, start + n):
            net.send_message(0x181, struct.pack("<ff", T, 0.0))  # the master's finger: warm
            sync(net, (c % 240) + 1)
        sdo_fence(remote)

    cycles(60, 0)
    heating = remote.sdo["current_A"].raw
    assert heating > 0.05  # telepresence: tracking a warm finger heats
    remote.sdo["mode"].raw = 0  # IDLE
    cycles(60, 60)
    assert remote.sdo["current_A"].raw == 0.0  # the idle ramp (4 A/s) has brought it to 0
    with pytest.raises(canopen.SdoAbortedError) as info:
        remote.sdo["mode"].raw = 2  # RENDER: the master's job, not the probe's
    assert info.value.code == 0x08000022  # refused for the present device state ...
    assert remote.sdo["mode"].raw == 0  # ... before it was stored
    remote.sdo["mode"].raw = 1
    cycles(60, 120)
    assert remote.sdo["current_A"].raw > 0.05  # back to telepresence, heating again


def test_the_od_shows_the_running_controller_and_writes_take_effect_at_the_next_sync(slave):
    """The parameters in the OD are the controller's (default_params read at run time, the rig's
    I_max), not the EDS placeholders; a write is taken at the next SYNC, not before; a value the
    controller refuses (or cannot run in its present state) is aborted and left unchanged; reset
    node brings the program's power-on parameters back."""
    from telethermo import sim
    from telethermo.control.params import default_params
    from telethermo.control.types import Role

    net, remote, frames, _ = slave
    p = default_params(Role.SLAVE)
    i_max = sim.build_rig(sim.load_scene(SCENE), "slave", seed=1).I_max_A
    f32 = lambda x: struct.unpack("<f", struct.pack("<f", x))[0]  # noqa: E731
    sdo = remote.sdo
    for name, value in (
        ("kp_A_per_C", p.kp_A_per_C),
        ("ki_A_per_C_s", p.ki_A_per_C_s),
        ("kQ_A_per_W", p.kQ_A_per_W),
        ("R_sensor_C_per_W", p.R_sensor_K_per_W),
        ("T_min_C", p.safety.T_min_C),
        ("T_max_C", p.safety.T_max_C),
        ("ramp_limit_C_per_s", p.safety.ramp_up_C_per_s),
        ("hot_threshold_C", p.safety.hot_C),
        ("neutral_C", p.safety.neutral_C),
        ("current_limit_A", p.safety.current_fraction * i_max),
        ("sink_trip_C", p.safety.sink_trip_C),
        ("mismatch_limit_C", p.safety.mismatch_C),
    ):
        assert sdo[name].raw == f32(value), name
    assert sdo["estimator"].raw == 1 and sdo["mode"].raw == 1  # flux estimator, telepresence

    m0 = frames.mark()
    net.send_message(0, bytes([0x01, SLAVE]))
    assert reaches_state(frames, m0, 5)
    counter = [0]

    def cycle(T=40.0):
        counter[0] += 1
        net.send_message(0x181, struct.pack("<ff", T, 0.0))  # the master's finger: warm
        sync(net, counter[0] % 240 + 1)
        sdo_fence(remote)
        return sdo["T_cmd_C"].raw, sdo["current_A"].raw

    for _ in range(40):
        cmd, cur = cycle()
    # the setpoint ramps towards the finger at the ramp limit: 5 °C/s x 10 ms per SYNC
    prev, _ = cycle()
    cmd, _ = cycle()
    assert cmd - prev == pytest.approx(p.safety.ramp_up_C_per_s * 0.01, abs=1e-4)
    sdo["ramp_limit_C_per_s"].raw = 1.0
    assert sdo["T_cmd_C"].raw == cmd  # no SYNC yet: nothing changed
    nxt, _ = cycle()
    assert nxt - cmd == pytest.approx(0.01, abs=1e-4)  # the very next SYNC ramps at 1 °C/s
    # gains: with kp at its maximum the current sits at the current limit from the next SYNC on
    _, cur = cycle()
    assert 0 < cur < 0.5 * p.safety.current_fraction * i_max
    sdo["kp_A_per_C"].raw = 20.0
    sdo["current_limit_A"].raw = 0.75
    assert sdo["current_A"].raw == cur
    _, cur = cycle()
    assert cur == pytest.approx(0.75, abs=1e-6)
    assert sdo["kp_A_per_C"].raw == 20.0 and sdo["current_limit_A"].raw == 0.75

    def refused(name, value):
        before = sdo[name].raw
        with pytest.raises(canopen.SdoAbortedError) as info:
            sdo[name].raw = value
        assert sdo[name].raw == before
        return info.value.code

    assert refused("estimator", 0) == 0x08000022  # the NARMA estimator needs a model: none loaded
    assert refused("estimator", 2) == 0x08000022
    assert (
        refused("T_min_C", 33.0) == 0x06090030
    )  # the neutral temperature (32 °C) would leave [T_min, T_max]
    assert refused("mode", 2) == 0x08000022
    assert refused("current_limit_A", 0.0) == 0x06090030
    # reset node: the program's power-on parameters again (not the EDS placeholders)
    m = frames.mark()
    net.send_message(0, bytes([0x81, SLAVE]))
    assert wait_for(lambda: (0x702, b"\x00") in frames.since(m), 10)
    assert sdo["kp_A_per_C"].raw == f32(p.kp_A_per_C) and sdo["ramp_limit_C_per_s"].raw == f32(
        p.safety.ramp_up_C_per_s
    )
    assert sdo["current_limit_A"].raw == f32(p.safety.current_fraction * i_max) and sdo["estimator"].raw == 1


def test_after_the_peers_return_only_peer_trips_are_cleared_another_latched_trip_keeps_the_cut(
    slave, tmp_path
):
    """What an operator saw once (safety_state 3 after the peer came back, EMCY register 0x19): the peer
    trip is cleared on the peer's return only when it is the only trip; a temperature trip latched before
    keeps the cut (the node says so in its log) until an operator reset (NMT reset node)."""
    net, remote, frames, _ = slave
    sdo = remote.sdo
    m0 = frames.mark()
    net.send_message(0, bytes([0x01, SLAVE]))
    assert reaches_state(frames, m0, 5)
    n = [0]

    def cycles(k, pdo=True):
        for _ in range(k):
            n[0] += 1
            if pdo:
                net.send_message(0x181, struct.pack("<ff", 30.0, 0.0))
            sync(net, n[0] % 240 + 1)
        sdo_fence(remote)

    cycles(20)
    assert sdo["safety_state"].raw < 2
    m = frames.mark()
    sdo["T_min_C"].raw = 28.0  # the probe sits at ~25 °C: now below T_min - 2 °C
    cycles(3)
    assert sdo["last_trip_code"].raw == 0x4220 and sdo["safety_state"].raw == 3  # surface_low: cut
    cycles(15, pdo=False)  # the peer's PDOs stop: peer_lost on top
    emcy = [d for _, d in frames.since(m, 0x82) if len(d) == 8]
    lost = [d for d in emcy if int.from_bytes(d[:2], "little") == 0x8130]
    assert lost and lost[0][2] & 0x18 == 0x18  # register: temperature + communication (+ generic)
    cycles(20)  # the peer is back
    assert sdo["safety_state"].raw == 3 and sdo["current_A"].raw == 0.0
    assert sdo["Error register"].raw & 0x08
    log = (tmp_path / "slave.log").read_text()
    assert "peer values back, but surface_low latched" in log
    m = frames.mark()
    net.send_message(0, bytes([0x81, SLAVE]))  # the operator's reset: power-on parameters, no trip
    assert wait_for(lambda: (0x702, b"\x00") in frames.since(m), 10)
    m0 = frames.mark()
    net.send_message(0, bytes([0x01, SLAVE]))
    assert reaches_state(frames, m0, 5)
    cycles(20)
    assert sdo["safety_state"].raw < 2 and sdo["Error register"].raw == 0
    assert sdo["T_min_C"].raw == 0.0  # the probe's power-on clamp


def test_the_oscillation_guard_threshold_is_a_stored_bus_parameter_in_range(slave, tmp_path):
    """osc_guard_C (0x2204) with canopen's SdoClient from the shipped slave.eds: the slave shows its guard's
    0.15 °C; 0.3 is written and read back; 2.0 and -0.1 lie outside 0..1 °C and are refused (too high, too
    low), the value unchanged. Saved (0x1010) and after a reset node, the node shows 0.3 again: the stored
    value replayed through the controller's parameters into the OD image (a value the mapping lost would
    show the controller's 0.15)."""
    net, remote, frames, _ = slave
    f32 = lambda x: struct.unpack("<f", struct.pack("<f", x))[0]  # noqa: E731
    guard = remote.sdo[0x2204]
    assert guard.name == "osc_guard_C" and guard.raw == f32(0.15)
    guard.raw = 0.3
    assert guard.raw == f32(0.3)
    codes = []
    for bad in (2.0, -0.1):
        with pytest.raises(canopen.SdoAbortedError) as info:
            guard.raw = bad
        codes.append(info.value.code)
        assert guard.raw == f32(0.3)
    assert codes == [0x06090031, 0x06090032]  # CiA 301: value too high, too low (0x0609003x: range)
    remote.sdo.download(0x1010, 1, b"save")
    assert "osc_guard_C" in (tmp_path / "slave-store.json").read_text(encoding="utf-8")
    m = frames.mark()
    net.send_message(0, bytes([0x81, SLAVE]))
    assert wait_for(lambda: (0x702, b"\x00") in frames.since(m), 10)
    assert guard.raw == f32(0.3)
