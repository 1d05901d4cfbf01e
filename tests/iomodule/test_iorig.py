"""The I/O rig driver (``--rig io --rig-config RIG.toml``, issue 24 item 1) against a real module process
on the hub: commissioning read back by the test's own canopen RemoteNode (from the module's EDS), inputs
by TPDO on the test's SYNC, the drive by RPDO; a refused configuration names the object and the abort code
(exit 2); a malformed RIG.toml is one line naming the file and the field (exit 2)."""

from __future__ import annotations

import logging

import subprocess
import sys
from pathlib import Path

import pytest

from telethermo.bus_config import path as bus_config_path
from telethermo.iomodule.iorig import IoRig, IoRigError
from telethermo.iomodule.rigconfig import RigConfigError, load_rig_config, parse_rig_config
from telethermo.transport.bus import parse_bus_string
from tests.iomodule.helpers import CONTROLLER_ID, MODULE_ID

SIM_TOML = bus_config_path("rig_io_sim.toml")
MASTER = Path(sys.executable).with_name("telethermo-master")


def _sync(bus, n: list[int] = [0]) -> None:
    """One SYNC with its counter (the module's 0x1019 is the network's 240: a SYNC without one is ignored)."""
    n[0] = n[0] % 240 + 1
    bus.network.sync.transmit(n[0])


def _rig(hub, text: str | None = None, tmp_path: Path | None = None) -> IoRig:
    cfg = load_rig_config(SIM_TOML) if text is None else parse_rig_config(text, "RIG.toml")
    transport = parse_bus_string(f"socketcand://127.0.0.1:{hub.port}/vcan0")
    return IoRig(cfg, transport=transport, controller_id=CONTROLLER_ID, period_s=0.01, lockstep=True)


@pytest.mark.slow
def test_commissioned_rig_reads_tpdos_on_sync_and_drives_by_rpdo(rig):
    hub, bus, _ = rig
    node = bus.node
    assert node.sdo[0x2100].raw == 400 and node.sdo[0x6443][1].raw == 0  # the module's traps, before
    io = _rig(hub).start()
    try:
        bus.sdo_settled()
        # what commissioning wrote, read by the test's own client from the module's EDS
        assert node.sdo[0x2100].raw == 10 and node.sdo[0x1006].raw == 10_000
        assert node.sdo[0x6443][1].raw == 1 and node.sdo[0x6444][1].raw == 0 and node.sdo[0x1029][1].raw == 0
        assert node.sdo[0x1016][1].raw == (CONTROLLER_ID << 16) | 150
        node.tpdo.read(from_od=False)
        assert [(v.od.index, v.od.subindex) for v in node.tpdo[1].map] == [(0x6401, k) for k in (1, 2, 3, 4)]
        assert [(v.od.index, v.od.subindex) for v in node.tpdo[2].map] == [(0x6401, 5), (0x6401, 6)]
        bus.wait(lambda: bus.module_state() == 0x05)  # the driver started it
        samples = []
        for k in range(3):
            _sync(bus)
            samples.append(io.read())
        s = samples[-1]
        assert s.t_s == pytest.approx(0.03)
        assert abs(s.T_sensor_C - node.sdo[0x6401][1].raw * 10 / 32768 * 10) < 1e-9  # scaled as configured
        assert 15 < s.T_sensor_C < 40 and 15 < s.T_sink_C < 40 and not s.contact and abs(s.current_A) < 1e-3
        io.apply_current(2.0)
        bus.wait(lambda: node.sdo[0x2101].raw == 6554)  # the RPDO applied: 2 A at 1 A/V
        _sync(bus)
        assert io.read().current_A == pytest.approx(2.0, abs=1e-3)  # the drive monitor, next input set
        io.apply_current(50.0)  # clipped to the drive's limit, 3 A
        bus.wait(lambda: node.sdo[0x2101].raw == round(3.0 * 3276.8))
        node.sdo[0x2110].raw = 1  # thermocouple opens: its sentinel, NaN
        _sync(bus)
        s = io.read()
        assert s.T_sensor_C != s.T_sensor_C and s.Q_W == s.Q_W
    finally:
        io.close()
    # closed: PRE-OPERATIONAL, output on substitute (the heartbeat timer may report the state before the
    # notifier thread has applied the output: both are waited for, a module left driving still fails)
    bus.wait(lambda: bus.module_state() == 0x7F and node.sdo[0x2101].raw == 0 and node.sdo[0x2102].raw == 1)


@pytest.mark.slow
def test_missing_inputs_time_out_then_read_nan(rig, caplog):
    hub, bus, _ = rig
    # a generous input timeout (1 s, not the shipped 5 ms): the read after a SYNC gets its inputs however
    # loaded the machine is; the reads without a SYNC still wait it out, count it and go stale
    text = SIM_TOML.read_text(encoding="utf-8").replace("stale_limit = 3", "stale_limit = 2")
    text = text.replace("input_timeout_ms = 5.0", "input_timeout_ms = 1000.0")
    assert "input_timeout_ms = 1000.0" in text
    cfg = parse_rig_config(text, "RIG.toml")
    io = IoRig(
        cfg,
        transport=parse_bus_string(f"socketcand://127.0.0.1:{hub.port}/vcan0"),
        controller_id=CONTROLLER_ID,
        period_s=0.01,
    ).start()
    try:
        # start() sent its NMT START on the driver's own connection: a SYNC of the test's connection may pass
        # it in the hub and reach a module still PRE-OPERATIONAL (no TPDOs): the heartbeat says when it runs
        bus.wait(lambda: bus.module_state() == 0x05)
        _sync(bus)
        assert io.read().T_sensor_C == io.read_sdo().T_sensor_C
        assert io.timeouts == 0
        first = io.read()  # no SYNC: no new inputs, the last sample once
        assert io.timeouts == 1 and first.T_sensor_C == first.T_sensor_C
        with caplog.at_level(logging.WARNING, logger="telethermo.iomodule.iorig"):
            assert io.read().T_sensor_C != io.read().T_sensor_C  # stale_limit reached: NaN
            # the node's log says which module went silent, once (not only the envelope's sensor trip)
            assert [r.getMessage() for r in caplog.records] == [
                "RIG.toml: no inputs for 2 periods from modules.io (node 3): every signal reads NaN (the "
                "envelope trips on it); is the module powered, on this bus, OPERATIONAL?"
            ]
            _sync(bus)
            back = io.read()  # the inputs of that SYNC
            assert back.T_sensor_C == back.T_sensor_C
            assert caplog.records[-1].getMessage() == "RIG.toml: inputs back after 3 periods"
    finally:
        io.close()


@pytest.mark.slow
def test_a_module_that_refuses_is_named_with_object_and_abort_code(rig, tmp_path):
    hub, bus, _ = rig
    # the sampling period is no PDO-mappable object: the module refuses the mapping entry (CiA 301 0x06040041)
    text = SIM_TOML.read_text(encoding="utf-8").replace(
        "object = 0x6401\nsubindex = 5", "object = 0x2100\nsubindex = 0"
    )
    with pytest.raises(IoRigError) as err:
        IoRig(
            parse_rig_config(text, "RIG.toml"),
            transport=parse_bus_string(f"socketcand://127.0.0.1:{hub.port}/vcan0"),
            controller_id=CONTROLLER_ID,
            period_s=0.01,
        ).start()
    msg = str(err.value)
    assert "modules.io" in msg and "0x1A01:1" in msg and "0x06040041" in msg, msg
    # the refused value decoded, and the file's entry that put the object there
    assert "= 0x21000010 (maps 0x2100:0, 16 bit) refused" in msg, msg
    assert "0x2100:0 is signals." in msg and "of the file: is it an object of this module" in msg, msg
    # the node program: one line, exit 2
    bad = tmp_path / "RIG.toml"
    bad.write_text(text, encoding="utf-8")
    proc = subprocess.run(
        [
            str(MASTER),
            "--rig",
            "io",
            "--rig-config",
            str(bad),
            "--bus",
            f"socketcand://127.0.0.1:{hub.port}/vcan0",
            "--cycles",
            "1",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "0x1A01:1" in lines[0] and "0x06040041" in lines[0], proc.stderr


@pytest.mark.parametrize(
    "edit, field, expected",
    [
        (
            ("subindex = 1\nvolts", "subindex = 300\nvolts"),
            "signals.T_sensor_C.subindex",
            "an integer in [0, 255]",
        ),
        (("[signals.Q_W]", "[signals.Q]"), "signals.Q", "one of"),
        (('module = "io"\nobject = 0x6411', 'module = "dio"\nobject = 0x6411'), "drive.module", "one of io"),
        (("limit_A = 3.0", "limit_A = -3.0"), "drive.limit_A", "a number > 0"),
        (("gain = 10.0                  # °C per V", "sign = 2"), "signals.T_sensor_C.sign", "1 or -1"),
        (("node_id = 3", "node_id = 300"), "modules.io.node_id", "an integer in [1, 127]"),
        (("sentinels = [32767, -32768]", "sentinels = [40000]"), "signals.T_sensor_C.sentinels", "16-bit"),
        (
            ("subindex = 6\ngain", "subindex = 5\ngain"),
            "signals.current_A.subindex",
            "an input no other signal",
        ),
        (
            ("stale_limit = 3", "stale_limit = 3\nsdo_timeout_ms = 5"),
            "sdo_timeout_ms",
            "a time in [10, 60000] ms",
        ),
    ],
)
def test_malformed_rig_toml_names_file_and_field(edit, field, expected):
    text = SIM_TOML.read_text(encoding="utf-8")
    assert edit[0] in text
    with pytest.raises(RigConfigError) as err:
        parse_rig_config(text.replace(edit[0], edit[1], 1), "RIG.toml")
    msg = str(err.value)
    assert msg.startswith(f"RIG.toml: {field}: expected") and expected in msg and "\n" not in msg, msg


@pytest.mark.slow  # runs the node program as a process
def test_malformed_rig_toml_exits_2_with_one_line(tmp_path):
    bad = tmp_path / "RIG.toml"
    bad.write_text(
        SIM_TOML.read_text(encoding="utf-8").replace("[signals.T_sink_C]", "[signals.T_heatsink]"),
        encoding="utf-8",
    )
    proc = subprocess.run(
        [str(MASTER), "--rig", "io", "--rig-config", str(bad), "--cycles", "1"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(
        f"telethermo-master: error: {bad}: signals.T_heatsink: expected one of"
    ), proc.stderr
    # the shipped examples load
    for name in ("rig_io_sim.toml", "rig_io_sim_slave.toml"):
        assert {s for s in load_rig_config(bus_config_path(name)).signals} >= {"T_sensor_C", "contact"}
    assert load_rig_config(bus_config_path("rig_io_sim_slave.toml")).modules["io"].node_id == MODULE_ID + 1


def test_sdo_timeout_of_the_rig_toml_is_the_commissionings_default():
    text = SIM_TOML.read_text(encoding="utf-8")
    cfg = parse_rig_config(
        text.replace("stale_limit = 3", "stale_limit = 3\nsdo_timeout_ms = 2500"), "RIG.toml"
    )
    assert cfg.sdo_timeout_ms == 2500.0 and parse_rig_config(text, "RIG.toml").sdo_timeout_ms == 1000.0
    kw = dict(transport=None, controller_id=CONTROLLER_ID, period_s=0.01)
    assert IoRig(cfg, **kw).sdo_timeout_s == 2.5
    assert IoRig(cfg, sdo_timeout_s=0.2, **kw).sdo_timeout_s == 0.2  # rig check's own


def test_a_module_that_is_not_there_is_one_line_saying_what_to_check(caplog):
    # no module on the bus: the driver's one line says what to check, and canopen's own "Transfer aborted"
    # ERROR line does not appear beside it
    text = SIM_TOML.read_text(encoding="utf-8").replace(
        "stale_limit = 3", "stale_limit = 3\nsdo_timeout_ms = 50"
    )
    rig = IoRig(
        parse_rig_config(text, "RIG.toml"),
        transport=parse_bus_string("virtual:tt-no-module"),
        controller_id=CONTROLLER_ID,
        period_s=0.01,
    )
    with caplog.at_level(logging.DEBUG, logger="canopen"), pytest.raises(IoRigError) as err:
        rig.start()
    msg = str(err.value)
    assert msg.startswith("RIG.toml: modules.io: node 3 does not answer SDO"), msg
    assert msg.endswith("is the module powered, set to node-ID 3, and on this bus (virtual:tt-no-module)?"), (
        msg
    )
    assert not [r for r in caplog.records if r.levelno >= logging.ERROR], caplog.records
