"""RIG.toml's ``[tem]`` table (issue 24): a lab's TEM constants reach the envelope's detached-sensor check
of a node on an I/O rig (``--rig io``), as a simulated rig's own TEM does; a bad value is refused in one line
naming the file and the field (the node program: exit 2). The shipped files carry the simulated module's
true TEM."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from telethermo.bus_config import path as bus_config_path
from telethermo.control.detach import tem_limits
from telethermo.control.safety_limits import SafetyLimits
from telethermo.control.types import Mode, Role
from telethermo.iomodule.rigconfig import RigConfigError, load_rig_config, parse_rig_config
from telethermo.nodes.options import NodeOptions
from telethermo.nodes.parts import build_parts
from telethermo.sim.compile import build_rig
from telethermo.sim.scene import load_scene
from telethermo.transport.bus import parse_bus_string
from tests.iomodule.helpers import CONTROLLER_ID

SIM_TOML = Path(bus_config_path("rig_io_sim.toml"))
MASTER = Path(sys.executable).with_name("telethermo-master")
#: a TEM unlike the envelope's defaults (the shipped 15 x 15 mm module), so that a lost value shows
LAB_TEM = {"alpha_V_K": 0.0532, "R_ohm": 2.17, "K_W_K": 0.412, "tau_V_K": -0.0031}


def with_tem(tem: dict[str, float] | None) -> str:
    """The shipped RIG.toml with its ``[tem]`` table replaced by ``tem`` (None: no table)."""
    text = SIM_TOML.read_text(encoding="utf-8")
    head = text[: text.index("\n[tem]")]
    assert "[tem]" not in head
    if tem is None:
        return head + "\n"
    return head + "\n[tem]\n" + "".join(f"{k} = {v!r}\n" for k, v in tem.items())


@pytest.mark.parametrize("name, side", [("rig_io_sim.toml", "master"), ("rig_io_sim_slave.toml", "slave")])
def test_shipped_files_carry_the_simulated_modules_true_tem(name, side):
    tem = load_rig_config(bus_config_path(name)).tem
    true = build_rig(load_scene("probe_touches_al_steel_wood"), side, seed=0).params.tem
    for key in ("alpha_V_K", "R_ohm", "K_W_K", "tau_V_K"):
        assert getattr(tem, key) == pytest.approx(getattr(true, key), rel=1e-6), key


def test_tem_limits_read_an_io_rigs_tem_and_nothing_without():
    class Io:  # the attributes tem_limits reads of an IoRig
        tem = parse_rig_config(with_tem(LAB_TEM), "RIG.toml").tem

    assert tem_limits(Io()) == {f"tem_{k}": v for k, v in LAB_TEM.items()}

    class Bare:
        tem = parse_rig_config(with_tem(None), "RIG.toml").tem

    assert Bare.tem is None and tem_limits(Bare()) == {}
    tau = parse_rig_config(with_tem({k: v for k, v in LAB_TEM.items() if k != "tau_V_K"}), "RIG.toml").tem
    assert tau.tau_V_K == 0.0  # optional: the Thomson term left out


@pytest.mark.slow  # a module process on a hub
@pytest.mark.parametrize("tem", [LAB_TEM, None], ids=["lab-tem", "no-tem"])
def test_a_node_on_an_io_rig_puts_the_files_tem_into_its_safety_limits(rig, tmp_path, tem):
    hub, _, _ = rig
    cfg = tmp_path / "RIG.toml"
    cfg.write_text(with_tem(tem), encoding="utf-8")
    opts = NodeOptions(role=Role.MASTER, rig="io", rig_config=cfg, timing="lockstep")
    parts = build_parts(
        opts,
        period_s=0.01,
        node_id=CONTROLLER_ID,
        transport=parse_bus_string(f"socketcand://127.0.0.1:{hub.port}/vcan0"),
    )
    want = tem if tem is not None else {k: getattr(SafetyLimits(), f"tem_{k}") for k in LAB_TEM}
    try:
        for mode in (Mode.TELEPRESENCE, Mode.IDLE, Mode.IDENTIFY):
            s = parts.params_for(mode).safety
            assert {k: getattr(s, f"tem_{k}") for k in LAB_TEM} == want, mode
    finally:
        parts.rig.close()


@pytest.mark.parametrize(
    "key, value, expected",
    [
        ("alpha_V_K", -0.01, "a number in [0, 1] V/K"),
        ("alpha_V_K", 12.5, "a number in [0, 1] V/K"),
        ("R_ohm", 0.0, "a number in [0.001, 100] ohm"),
        ("K_W_K", 65.0, "a number in [0.0001, 10] W/K"),
        ("tau_V_K", 0.5, "a number in [-0.1, 0.1] V/K"),
        ("R_ohm", "1 ohm", "a number in [0.001, 100] ohm"),
        ("K_W_K", float("nan"), "a number in [0.0001, 10] W/K"),
    ],
)
def test_a_bad_tem_value_is_refused_naming_file_and_field(key, value, expected):
    with pytest.raises(RigConfigError) as err:
        parse_rig_config(with_tem(LAB_TEM | {key: value}), "RIG.toml")
    msg = str(err.value)
    assert msg.startswith(f"RIG.toml: tem.{key}: expected {expected}") and "\n" not in msg, msg


def test_a_missing_or_unknown_tem_field_is_refused():
    with pytest.raises(
        RigConfigError, match=r"^RIG.toml: tem.K_W_K: expected a number in \[0.0001, 10\] W/K \(missing\)"
    ):
        parse_rig_config(with_tem({k: v for k, v in LAB_TEM.items() if k != "K_W_K"}), "RIG.toml")
    with pytest.raises(RigConfigError, match=r"^RIG.toml: tem.seebeck: expected one of"):
        parse_rig_config(with_tem(LAB_TEM | {"seebeck": 0.05}), "RIG.toml")


@pytest.mark.slow  # runs the node program as a process
def test_the_node_program_refuses_a_bad_tem_value_in_one_line_exit_2(tmp_path):
    bad = tmp_path / "RIG.toml"
    bad.write_text(with_tem(LAB_TEM | {"R_ohm": -1.0}), encoding="utf-8")
    proc = subprocess.run(
        [str(MASTER), "--rig", "io", "--rig-config", str(bad), "--cycles", "1"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert lines == [
        f"telethermo-master: error: {bad}: tem.R_ohm: expected a number in [0.001, 100] ohm, got -1.0"
    ], proc.stderr
