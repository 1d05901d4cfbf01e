"""telethermo.inputfile, the one reader of TOML input files (issue 26 item 5): every error is one line naming
the file and the line (a syntax error) or the field and what was expected; and each reader ported onto it
turns a malformed file into that line, through the real loader or program, exit 2 and no traceback.

Exit-2 tests that exist elsewhere and are not repeated here: the node program on a bad RIG.toml
(tests/iomodule/test_iorig.py, test_rig_tem.py), ``telethermo session`` on a cut-short scene
(tests/sim/test_scene_truncated.py), ``telethermo identify --tem`` on a bad [tem] table
(tests/sim/test_scene_tem.py)."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import pytest

from telethermo.cli.main import EXIT_USAGE, main as cli_main
from telethermo.control.gainsfile import GAINS_FORMAT, apply_marks, load_gains
from telethermo.control.later_rc import load_rc_table
from telethermo.control.material_id import load_effusivity_table
from telethermo.control.render_table import load_render_table
from telethermo.control.types import Role
from telethermo.control.virtual_object import load_object_table
from telethermo.device.netconfig import NetworkConfigError, load_network
from telethermo.ident import ModelFileError, load_model
from telethermo.inputfile import (
    ABSENT,
    InputFileError,
    Section,
    load_json,
    load_toml,
    parse_json,
    parse_toml,
)
from telethermo.iomodule.rigconfig import RigConfigError, load_rig_config
from telethermo.nodes.main import run_node
from telethermo.sim.errors import SceneError
from telethermo.sim.scene import load_scene
from telethermo.bus_config import path as bus_config_path

SIM_RIG = bus_config_path("rig_io_sim.toml")


def one_line(exc: BaseException) -> str:
    msg = str(exc)
    assert msg and "\n" not in msg, msg
    return msg


# ------------------------------------------------------------------------------------------ loading a file
def test_a_toml_syntax_error_names_the_file_and_its_line(tmp_path):
    p = tmp_path / "a.toml"
    p.write_text('[bus]\nbitrate = 1000000\nchannel = "x\n', encoding="utf-8")
    with pytest.raises(InputFileError) as err:
        load_toml(p)
    assert one_line(err.value).startswith(f"{p}: line 3: not valid TOML (")
    assert err.value.file == str(p) and err.value.field == "line 3"
    # a document cut short names its last line, and text given as a string names its source
    with pytest.raises(InputFileError, match=r"^RIG.toml: line 2: not valid TOML \(.*end of document"):
        parse_toml("[a]\nx = [1,", "RIG.toml")


def test_a_missing_unreadable_or_non_utf8_file_is_one_line(tmp_path):
    with pytest.raises(InputFileError) as err:
        load_toml(tmp_path / "none.toml", what="a network settings TOML file")
    assert (
        one_line(err.value)
        == f"{tmp_path / 'none.toml'}: no such file (expected a network settings TOML file)"
    )
    with pytest.raises(InputFileError, match=r": a folder, not a file \(expected a TOML file\)$"):
        load_toml(tmp_path)
    p = tmp_path / "latin1.toml"
    p.write_bytes(b'[a]\nname = "x"\nplace = "M\xfcnchen"\n')
    with pytest.raises(InputFileError) as err:
        load_toml(p)
    assert one_line(err.value) == f"{p}: line 3: not UTF-8 text (byte 0xFC)"


def test_a_caller_gets_its_own_error_type():
    with pytest.raises(NetworkConfigError) as err:
        parse_toml("x = ", "net.toml", NetworkConfigError)
    assert isinstance(err.value, InputFileError) and isinstance(err.value, ValueError)


# ------------------------------------------------------------------------------------------- JSON files
def test_a_json_syntax_error_names_the_file_its_line_and_column(tmp_path):
    p = tmp_path / "gains.json"
    p.write_text('{\n  "format": "x",\n  "master": {"kp": 1.0\n  "slave": {}\n}\n', encoding="utf-8")
    with pytest.raises(InputFileError) as err:
        load_json(p)
    assert one_line(err.value) == f"{p}: line 4 column 3: not valid JSON (Expecting ',' delimiter)"
    assert err.value.file == str(p) and err.value.field == "line 4"
    with pytest.raises(
        InputFileError, match=r"^m.json: line 1 column 12: not valid JSON \(Expecting value\)$"
    ):
        parse_json('{"theta": [', "m.json")


def test_a_json_file_that_is_missing_unreadable_not_utf8_or_too_big_is_one_line(tmp_path):
    with pytest.raises(NetworkConfigError) as err:
        load_json(tmp_path / "none.json", "a gains file", NetworkConfigError)
    assert one_line(err.value) == f"{tmp_path / 'none.json'}: no such file (expected a gains file)"
    with pytest.raises(InputFileError, match=r": a folder, not a file \(expected a JSON file\)$"):
        load_json(tmp_path)
    p = tmp_path / "latin1.json"
    p.write_bytes(b'{"a": 1,\n "place": "M\xfcnchen"}\n')
    with pytest.raises(InputFileError) as err:
        load_json(p)
    assert one_line(err.value) == f"{p}: line 2: not UTF-8 text (byte 0xFC)"
    # Python's limits are errors of the file too, not a traceback: an integer of 5000 digits, deep nesting
    with pytest.raises(InputFileError, match=r"^big.json: not valid JSON \(Exceeds the limit"):
        parse_json('{"n": ' + "9" * 5000 + "}", "big.json")
    with pytest.raises(InputFileError, match=r"^deep.json: not valid JSON \(maximum recursion depth"):
        parse_json('{"a": ' + "[" * 100_000 + "]" * 100_000 + "}", "deep.json")


@pytest.mark.parametrize(
    "text, kind", [("[1, 2]", "an array"), ('"gains"', "a string"), ("3.5", "a number"), ("null", "null")]
)
def test_a_json_top_level_that_is_not_an_object_is_one_line(text, kind):
    with pytest.raises(InputFileError) as err:
        parse_json(text, "model.json")
    assert one_line(err.value) == f"model.json: top level: expected a JSON object {{...}}, got {kind}"


def test_json_fields_read_through_the_section_with_dotted_names():
    doc = parse_json(
        '{"format": "g/1", "master": {"kp": 2, "ki": 0.5, "on": true, "x": NaN}, "list": [1, 2.5]}', "g.json"
    )
    master = doc.table("master")
    kp = master.float("kp", positive=True)
    assert kp == 2.0 and isinstance(kp, float) and master.float("ki") == 0.5
    assert doc.str("format", choices=("g/1",)) == "g/1" and doc.list("list") == [1, 2.5]
    assert master.bool("on") is True and master.int("n", 4) == 4
    cases = [
        (lambda: master.float("on"), "g.json: master.on: expected a finite number, got True"),
        (lambda: master.int("on"), "g.json: master.on: expected an integer, got True"),
        (lambda: master.float("x"), "g.json: master.x: expected a finite number, got nan"),
        (lambda: doc.table("slave"), "g.json: slave: expected a table (missing)"),
        (lambda: doc.table("format", expected="an object"), "g.json: format: expected an object, got 'g/1'"),
        (lambda: master.table("kp"), "g.json: master.kp: expected a table, got 2"),
    ]
    for read, message in cases:
        with pytest.raises(InputFileError) as err:
            read()
        assert one_line(err.value) == message


# ------------------------------------------------------------------------------------ reading the fields
DOC = {"nodes": {"master": {"node_id": 200, "eds": "master.eds"}}, "sync": {"period_s": "fast"}}


def section(name: str, dotted: bool = False, allowed: set[str] | None = None) -> Section:
    return Section("net.toml", "", DOC, dotted=dotted).table(name, allowed)


@pytest.mark.parametrize(
    "read, message",
    [
        (
            lambda: section("nodes").table("master").int("node_id", 1, 1, 127),
            "net.toml: [nodes.master] node_id: expected an integer in [1, 127], got 200",
        ),
        (
            lambda: section("sync").float("period_s", 0.01, 0.0001, 1.0, " s"),
            "net.toml: [sync] period_s: expected a number in [0.0001, 1] s, got 'fast'",
        ),
        (
            lambda: section("nodes").table("master", {"node_id"}),
            "net.toml: [nodes.master] eds: expected one of node_id (an unknown key)",
        ),
        (
            lambda: section("nodes").table("master").float("R_ohm", ABSENT, 0.0, 100.0, " ohm", lo_open=True),
            "net.toml: [nodes.master] R_ohm: expected a number in (0, 100] ohm (missing)",
        ),
        (
            lambda: section("nodes").table("master").str("eds", choices=("a.eds", "b.eds")),
            "net.toml: [nodes.master] eds: expected one of a.eds, b.eds, got 'master.eds'",
        ),
        (
            lambda: section("nodes").table("master").bool("eds"),
            "net.toml: [nodes.master] eds: expected true or false, got 'master.eds'",
        ),
        (
            lambda: section("nodes").table("master").list("eds"),
            "net.toml: [nodes.master] eds: expected a list, got 'master.eds'",
        ),
        (
            lambda: section("nodes").table("master").table("eds"),
            "net.toml: [nodes.master.eds]: expected a table, got 'master.eds'",
        ),
        (lambda: section("bus"), "net.toml: bus: expected a table (missing)"),
        (
            lambda: section("nodes", dotted=True).table("master").int("node_id", 1, 1, 127),
            "net.toml: nodes.master.node_id: expected an integer in [1, 127], got 200",
        ),
        (
            lambda: Section("net.toml", "", {"n": 10**400}).float("n", positive=True),
            f"net.toml: n: expected a number > 0, got {10**400!r}",
        ),
    ],
)
def test_a_field_error_is_one_line_naming_file_field_and_expectation(read, message):
    with pytest.raises(InputFileError) as err:
        read()
    assert one_line(err.value) == message


def test_good_fields_read_with_their_types_and_defaults():
    t = Section("f.toml", "a", {"n": 3, "x": 2, "s": "io", "b": False, "l": [1]}, {"n", "x", "s", "b", "l"})
    assert t.int("n", ABSENT, 1, 5) == 3 and t.int("m", 7) == 7
    x = t.float("x", ABSENT, 0.0, 10.0)
    assert x == 2.0 and isinstance(x, float) and t.float("y", None) is None
    assert t.str("s", choices=("io", "sim")) == "io" and t.bool("b") is False and t.list("l") == [1]
    assert t.table("sub", None, {}).raw == {}


# ------------------------------------------------------------------------ each ported reader, end to end
@pytest.fixture(autouse=True)
def root_logging():
    """The node program, run in-process, sets up the root logger (force=True): give the next test its own."""
    root = logging.getLogger()
    handlers, level = root.handlers[:], root.level
    yield
    root.handlers[:] = handlers
    root.setLevel(level)


def test_a_bad_network_file_stops_the_node_program_with_exit_2_and_one_line(tmp_path, capsys):
    bad = tmp_path / "network.toml"
    bad.write_text("[heartbeat]\nproducer_ms = 100\nconsumer_ms = 80\n", encoding="utf-8")
    code = run_node(
        Role.MASTER, ["--scene", "free_pad_identification", "--network", str(bad), "--cycles", "1"]
    )
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    assert err.startswith(f"telethermo-master: error: {bad}: [heartbeat] consumer_ms: expected an integer >")


def test_a_bad_network_file_stops_the_cli_with_exit_2_and_one_line(tmp_path, capsys):
    bad = tmp_path / "network.toml"
    bad.write_text("[sync]\nperiod_s = 0.010\nlock_step = true\n", encoding="utf-8")
    code = cli_main(["get", "--network", str(bad), "master", "mode"])
    err = capsys.readouterr().err
    assert code == EXIT_USAGE and err.count("\n") == 1 and "Traceback" not in err, err
    assert f"{bad}: [sync] lock_step: expected one of counter_overflow, lockstep, period_s, producer" in err


def test_a_bad_rig_toml_stops_the_node_program_in_process(tmp_path, capsys):
    """The in-process twin of the slow process test of tests/iomodule: refused before any module is
    commissioned."""
    bad = tmp_path / "RIG.toml"
    bad.write_text(SIM_RIG.read_text(encoding="utf-8").replace("node_id = 3", "node_id = 300", 1), "utf-8")
    with pytest.raises(RigConfigError, match=r"modules.io.node_id: expected an integer in \[1, 127\]"):
        load_rig_config(bad)
    code = run_node(Role.MASTER, ["--bus", "virtual:tt-inputfile", "--rig", "io", "--rig-config", str(bad)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    assert f"{bad}: modules.io.node_id: expected an integer in [1, 127], got 300" in err


def test_a_bad_scene_stops_the_node_program_with_exit_2_and_one_line(tmp_path, capsys):
    bad = tmp_path / "scene.toml"
    bad.write_text("[scene]\nduration_s = 1.0\nperiod_s = 5.0\n", encoding="utf-8")
    with pytest.raises(SceneError) as exc:
        load_scene(bad)
    assert one_line(exc.value) == f"{bad}: field 'scene.period_s': expected a number in [0.0001, 1], got 5.0"
    code = run_node(Role.MASTER, ["--bus", "virtual:tt-inputfile", "--scene", str(bad), "--cycles", "1"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    assert str(exc.value) in err


def test_a_broken_rig_driver_settings_file_stops_the_node_program(tmp_path, capsys):
    bad = tmp_path / "driver.toml"
    bad.write_text("port = \n", encoding="utf-8")
    argv = ["--bus", "virtual:tt-inputfile", "--rig", "tests.nodes.rig_factories:configured"]
    code = run_node(Role.MASTER, [*argv, "--rig-config", str(bad)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    assert f"--rig-config {bad}: line 1: not valid TOML" in err


@pytest.mark.parametrize(
    "load, text, message",
    [
        (load_render_table, "[wood]\nbeta = 0\n", "[wood] beta: expected a number > 0, got 0"),
        (load_render_table, "[wood]\nbeta = 1.0\nbetta = 2\n", "[wood] betta: expected one of beta,"),
        (
            load_effusivity_table,
            "[oak]\nbeta = 1.0\neffusivity = -3\n",
            "[oak] effusivity: expected a number > 0",
        ),
        (
            load_object_table,
            "[finger]\nb_W_s05_m2K = 951.0\n[oak]\nlambda_W_mK = 0.2\n",
            "[oak] rho_c_J_m3K:",
        ),
        (
            load_rc_table,
            '[[entry]]\nmaterial = "oak"\nthickness_mm = 1.0\nback = "adiabatic"\nload_g = 0.0\n'
            "tau_s = -2.0\nfinal_fraction = 0.2\n",
            "[entry[0]] tau_s: expected a time > 0 s, got -2.0",
        ),
        (load_rc_table, "entry = []\n", "entry: expected a non-empty array of tables [[entry]], got []"),
    ],
)
def test_the_control_tables_name_file_and_field(tmp_path, load, text, message):
    p = tmp_path / "table.toml"
    p.write_text(text, encoding="utf-8")
    with pytest.raises(InputFileError) as err:
        load(p)
    assert one_line(err.value).startswith(f"{p}: ") and message in str(err.value), err.value
    with pytest.raises(ValueError, match=r"no such file"):
        load(tmp_path / "none.toml")


def test_the_shipped_files_load_unchanged():
    assert load_network().node("slave").node_id == 2
    assert load_rig_config(SIM_RIG).modules
    assert len(load_render_table()) == len(load_effusivity_table()) + 1
    assert load_object_table().canonical("wood") == "oak" and load_rc_table()
    assert Path(load_scene("free_pad_identification").path).is_file()


# ----------------------------------------------------------------------------- the JSON readers, end to end
def gains_doc(**changes) -> dict:
    doc = {"format": GAINS_FORMAT, "apply": apply_marks(), "master": {"kp_A_per_C": 1.5}, "slave": {}}
    return {k: v for k, v in dict(doc, **changes).items() if v is not None}


@pytest.mark.parametrize(
    "doc, message",
    [
        (gains_doc(format="gains/2"), "format: expected one of telethermo.gains/1, got 'gains/2'"),
        (gains_doc(slave=None), "slave: expected an object of gains (missing)"),
        (gains_doc(slave=[1.0]), "slave: expected an object of gains, got [1.0]"),
        (gains_doc(master={"kp_A_per_C": True}), "master.kp_A_per_C: expected a finite number, got True"),
        (gains_doc(master={"kp_A_per_C": -1}), "master.kp_A_per_C: expected >= 0.0, got -1.0"),
        (gains_doc(master={"kp": 1}), "master.kp: expected one of kQ_A_per_W, kiQ_A_per_W_s, ki_A_per_C_s,"),
    ],
)
def test_a_bad_gains_file_names_file_and_field(tmp_path, doc, message):
    p = tmp_path / "gains.json"
    p.write_text(json.dumps(doc), encoding="utf-8")
    with pytest.raises(InputFileError) as err:
        load_gains(p)
    assert one_line(err.value).startswith(f"{p}: {message}"), err.value


@pytest.mark.parametrize(
    "text, message",
    [
        (
            '{"format": "telethermo.gains/1",\n "master": {"kp_A_per_C": 1.5,}}',
            "line 2 column 31: not valid JSON",
        ),
        (
            json.dumps(gains_doc(apply={"mode": "render", "sdo": [], "restart": []})),
            "apply.mode: expected one of",
        ),
        (
            json.dumps(gains_doc(apply={"mode": "telepresence", "sdo": "kp_A_per_C"})),
            "apply.sdo: expected a list",
        ),
    ],
)
def test_a_bad_gains_file_stops_apply_gains_with_exit_2_and_one_line(tmp_path, capsys, text, message):
    bad = tmp_path / "gains.json"
    bad.write_text(text, encoding="utf-8")
    code = cli_main(["apply-gains", "--bus", "virtual:tt-inputfile", str(bad), "master"])
    out, err = capsys.readouterr()
    assert code == EXIT_USAGE and out == "" and err.count("\n") == 1 and "Traceback" not in err, err
    assert err.startswith(f"telethermo apply-gains: error: {bad}: {message}"), err
    code = cli_main(["apply-gains", "--bus", "virtual:tt-inputfile", str(tmp_path / "none.json")])
    assert code == EXIT_USAGE and "none.json: no such file (expected a gains file" in capsys.readouterr().err


NODE_ARGS = ["--bus", "virtual:tt-inputfile", "--scene", "free_pad_identification", "--cycles", "1"]


@pytest.mark.parametrize(
    "text, message",
    [
        (
            '{"format": "telethermo-tem-model",\n "format_version": 1,,}',
            "line 2 column 22: not valid JSON (Expecting property name",
        ),
        ("[]", "top level: expected a JSON object {...}, got an array"),
        ('{"format": "telethermo-tem-model", "format_version": true}', "field 'format_version': expected 1"),
        (
            '{"format": "telethermo-tem-model", "format_version": 1, "temperature": {"kind": "narma", '
            '"orders": {"n": 2, "m": 1, "p": true, "q": 0}}}',
            "field 'temperature.orders.p': expected an integer in [0, 8], got True",
        ),
    ],
)
def test_a_bad_model_file_stops_the_node_program_with_exit_2_and_one_line(tmp_path, capsys, text, message):
    bad = tmp_path / "model.json"
    bad.write_text(text, encoding="utf-8")
    with pytest.raises(ModelFileError) as exc:
        load_model(bad)
    assert one_line(exc.value).startswith(f"model file {bad}: {message}"), exc.value
    assert exc.value.path == exc.value.file == str(bad)
    code = run_node(Role.MASTER, [*NODE_ARGS, "--model", str(bad)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    assert str(exc.value) in err


def test_a_broken_gains_file_stops_the_node_program_with_exit_2_and_one_line(tmp_path, capsys):
    bad = tmp_path / "gains.json"
    bad.write_bytes(b'{"format": "telethermo.gains/1", "master": {"kp_A_per_C": 1.5\xb5}}')
    code = run_node(Role.MASTER, [*NODE_ARGS, "--gains", str(bad)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    assert f"--gains: {bad}: line 1: not UTF-8 text (byte 0xB5)" in err


@pytest.mark.parametrize(
    "key, value, rng", [("kp_A_per_C", 99.0, "0 .. 20"), ("kQ_A_per_W", -25.0, "-20 .. 20")]
)
def test_a_gain_beyond_the_od_range_stops_the_node_program(tmp_path, capsys, key, value, rng):
    # a value the node's own OD would refuse by SDO (0x2200..0x2202, EDS range) must not start the node either
    # (telethermo apply-gains refuses the same file); CoreParams alone accepted kp 99
    doc = {"format": GAINS_FORMAT, "master": {key: value}, "slave": {}}
    path = tmp_path / "gains.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    code = run_node(Role.MASTER, [*NODE_ARGS, "--gains", str(path)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    assert f"master.{key} = {value:g} is out of the object dictionary's range {rng}" in err, err


def test_a_display_only_scene_given_to_the_slave_is_one_line(capsys):
    # sim.build_rig refuses a 'virtual' scene for the probe; the node program printed its traceback
    scene = Path(__file__).resolve().parents[1] / "sim" / "scenes" / "free_pad_identification.toml"
    code = run_node(Role.SLAVE, ["--scene", str(scene)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    assert "field 'scene.kind': expected a scene with a slave rig ('telepresence'), got 'virtual'" in err


def test_a_rig_toml_names_its_controller_and_the_other_side_refuses_it(tmp_path, capsys):
    # the slave's rig file given to the master: the master would commission the slave's module to watch it
    slave_rig = bus_config_path("rig_io_sim_slave.toml")
    assert (load_rig_config(SIM_RIG).controller, load_rig_config(slave_rig).controller) == ("master", "slave")
    code = run_node(
        Role.MASTER, ["--bus", "virtual:tt-inputfile", "--rig", "io", "--rig-config", str(slave_rig)]
    )
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    assert "controller = 'slave': this rig is driven by the slave's node, not by telethermo-master" in err
    bad = tmp_path / "RIG.toml"
    bad.write_text(
        SIM_RIG.read_text(encoding="utf-8").replace('controller = "master"', 'controller = "left"')
    )
    with pytest.raises(RigConfigError, match=r"controller: expected one of master, slave, got 'left'"):
        load_rig_config(bad)
    bad.write_text(SIM_RIG.read_text(encoding="utf-8").replace('controller = "master"', ""))
    assert load_rig_config(bad).controller is None  # not said: rig check takes the master, with a note
    code = cli_main(["rig", "check", "--rig-config", str(bad), "--bus", "virtual:nobody", "--timeout", "0.2"])
    assert "rig check: note: no NODE given" in capsys.readouterr().err
