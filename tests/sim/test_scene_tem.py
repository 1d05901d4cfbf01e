"""A scene's [tem] section and ``telethermo identify --tem``: the module round-trips, per-couple values
scale, the module really drives the rig, and bad values give one line naming the file, field and
expectation."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from telethermo import sim
from telethermo.sim.errors import SceneError
from telethermo.sim.tem import TEM_FILE, TEMParams, load_rig_params, load_tem_file, tem_section
from telethermo.cli import identify as identify_cli
from telethermo.cli.main import main as cli_main
from telethermo.ident import UnstableModelError

BASE = """[scene]
name = "tem_scene"
kind = "virtual"
duration_s = 1.0

"""


def toml_table(name: str, d: dict) -> str:
    def val(v):
        return str(v).lower() if isinstance(v, bool) else repr(v)

    return f"[{name}]\n" + "".join(f"{k} = {val(v)}\n" for k, v in d.items())


def write_scene(tmp_path, tem: dict) -> str:
    p = tmp_path / "scene.toml"
    p.write_text(BASE + toml_table("tem", tem), encoding="utf-8")
    return str(p)


def test_the_default_module_round_trips_through_a_scene(tmp_path):
    default = load_rig_params()
    sc = sim.load_scene(write_scene(tmp_path, tem_section(default.tem)))
    assert sc.rig_params == default  # every TEM field and the rest of the rig unchanged


def test_per_couple_values_scale_with_the_couples_and_the_module_drives_the_rig(tmp_path):
    tem = {
        "couples": 71,
        "seebeck_per_couple_V_K": 4.0e-4,
        "R_per_couple_ohm": 0.025,
        "K_per_couple_W_K": 0.0015,
        "plate_C_J_K": 1.1,
        "Imax_A": 6.0,
        "thomson_V_K": 0.0,
    }
    sc = sim.load_scene(write_scene(tmp_path, tem))
    t = sc.rig_params.tem
    assert (t.alpha_V_K, t.R_ohm, t.K_W_K) == pytest.approx((71 * 4.0e-4, 71 * 0.025, 71 * 0.0015), rel=1e-12)
    assert (t.plate_C_J_K, t.I_max_A, t.tau_V_K) == (1.1, 6.0, 0.0)
    rig = sim.build_rig(sc, "master", noise=False)
    assert rig.I_max_A == 6.0
    # the same current heats the bigger module's pad differently from the default one
    default = sim.build_rig(dataclasses.replace(sc, rig_params=load_rig_params()), "master", noise=False)
    for r in (rig, default):
        r.apply_current(1.0)
        r.advance(2.0)
    assert abs(rig.truth().T_pad_C - default.truth().T_pad_C) > 0.5
    # a --tem file uses the same table
    p = tmp_path / "module.toml"
    p.write_text(toml_table("tem", tem), encoding="utf-8")
    assert load_tem_file(p) == sc.rig_params


GOOD = {"seebeck_V_K": 0.0125, "R_ohm": 0.97, "K_W_K": 0.065, "plate_C_J_K": 0.62, "Imax_A": 3.0}


@pytest.mark.parametrize(
    "change, field, expected",
    [
        ({"seebeck_V_K": -0.01}, "tem.seebeck_V_K", "a number in (0, 1000]"),
        ({"R_ohm": "one"}, "tem.R_ohm", "a number in"),
        ({"K_W_K": True}, "tem.K_W_K", "a number in"),
        ({"Imax_A": None}, "tem.Imax_A", "a number in (0, 100] (missing)"),
        ({"plate_C_J_K": None}, "tem.plate_C_J_K", "a number in (0, 1000] (missing)"),
        ({"Imax": 3.0}, "tem.Imax", "(an unknown key)"),
        ({"R_per_couple_ohm": 0.03, "couples": 31}, "tem.R_ohm", "exactly one"),
        ({"R_ohm": None, "R_per_couple_ohm": 0.03}, "tem.couples", "the number of couples"),
        ({"couples": 2.5}, "tem.couples", "an integer"),
        ({"sink_plate_C_J_K": 0.5}, "tem.pad_plate_C_J_K", "the same capacity for both plates"),
        ({"thomson_V_K": float("nan")}, "tem.thomson_V_K", "a number in [-1, 1]"),
    ],
)
def test_bad_tem_values_give_one_line_naming_file_field_and_expectation(tmp_path, change, field, expected):
    tem = {**GOOD, **change}
    tem = {k: v for k, v in tem.items() if v is not None}
    path = write_scene(tmp_path, tem).replace("\\", "/")
    with pytest.raises(SceneError) as ei:
        sim.load_scene(path)
    msg = str(ei.value)
    assert "\n" not in msg and msg.startswith(f"{path}: field '{field}': expected ") and expected in msg, msg


def test_a_tem_table_that_is_not_a_table_is_refused(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text('tem = "big"\n' + BASE, encoding="utf-8")
    with pytest.raises(SceneError, match=r"field 'tem': expected a table \[tem\]"):
        sim.load_scene(p)


def test_identify_tem_option_reports_a_bad_file_in_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text(toml_table("tem", {**GOOD, "Imax_A": 0}), encoding="utf-8")
    code = cli_main(["identify", "--tem", str(bad), "--out", str(tmp_path / "m.json"), "--quiet"])
    err = capsys.readouterr().err.strip()
    assert (
        code == 2
        and "\n" not in err
        and f"{bad}: field 'tem.Imax_A': expected a number in (0, 100], got 0" in err
    )
    missing = tmp_path / "none.toml"
    assert cli_main(["identify", "--tem", str(missing), "--out", str(tmp_path / "m.json"), "--quiet"]) == 2
    assert "no such file (expected a TOML file with a [datasheet] table" in capsys.readouterr().err


def _stop_before_the_experiment(monkeypatch) -> list:
    """Replace the experiment by a stub that keeps the rig it was given and refuses the model (exit 1)."""
    rigs: list = []

    def stub(rig, **_kw):
        rigs.append(rig)
        raise UnstableModelError("stub: the experiment is not run in this test")

    monkeypatch.setattr(identify_cli, "identify_rig", stub)
    return rigs


def test_identify_tem_loads_the_default_file_its_help_names(tmp_path, monkeypatch, capsys):
    with pytest.raises(SystemExit):
        cli_main(["identify", "--help"])
    help_text = " ".join(capsys.readouterr().out.split())
    assert "sim/data/tem_15x15.toml" in help_text
    default = Path(__file__).resolve().parents[2] / "sim" / "data" / "tem_15x15.toml"
    assert default.resolve() == TEM_FILE.resolve()
    assert load_tem_file(default) == load_rig_params()  # the same rig as no --tem at all
    rigs = _stop_before_the_experiment(monkeypatch)
    code = cli_main(["identify", "--tem", str(default), "--out", str(tmp_path / "m.json"), "--quiet"])
    assert code == 1 and "stub: the experiment is not run" in capsys.readouterr().err  # past loading
    assert rigs and rigs[0].I_max_A == 3.0


def test_identify_tem_takes_a_labs_copy_of_the_default_file(tmp_path, monkeypatch, capsys):
    lab = tmp_path / "lab_module.toml"
    lab.write_text(TEM_FILE.read_text(encoding="utf-8").replace("Imax_A = 3.0", "Imax_A = 6.0"), "utf-8")
    params = load_tem_file(lab)
    assert params.tem == TEMParams.from_datasheet(
        6.0, 3.75, 67.0, 27.0, tau_V_K=1.9e-3, plate_C_J_K=0.62
    )  # derived as the simulator derives the shipped module
    assert params.with_(tem=load_rig_params().tem) == load_rig_params()  # the rest of the rig as written
    rigs = _stop_before_the_experiment(monkeypatch)
    code = cli_main(["identify", "--tem", str(lab), "--out", str(tmp_path / "m.json"), "--quiet"])
    assert code == 1 and rigs and rigs[0].I_max_A == 6.0
    # a bad rating in a datasheet file: one line naming the file and the field
    lab.write_text(TEM_FILE.read_text(encoding="utf-8").replace("Vmax_V = 3.75", "Vmax_V = -1"), "utf-8")
    with pytest.raises(SceneError, match=r"field 'datasheet\.Vmax_V'"):
        load_tem_file(lab)


def test_a_tem_file_with_neither_table_says_which_formats_it_takes(tmp_path):
    p = tmp_path / "empty.toml"
    p.write_text("[module]\nside_mm = 15.0\n", encoding="utf-8")
    with pytest.raises(SceneError) as ei:
        load_tem_file(p)
    msg = str(ei.value)
    assert "\n" not in msg and "[datasheet]" in msg and "sim/data/tem_15x15.toml" in msg and "[tem]" in msg
