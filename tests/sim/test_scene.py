"""Scenes: the shipped ones load and say what the issue asks; malformed ones fail clearly."""

from __future__ import annotations

import pytest

from telethermo import sim
from telethermo.sim.errors import SceneError
from telethermo.sim.scene import SCENES_DIR


def test_shipped_scenes_load():
    names = sim.shipped_scenes()
    for n in ("finger_on_display", "probe_touches_al_steel_wood", "virtual_materials"):
        assert n in names
    for n in names:
        s = sim.load_scene(n)
        assert s.duration_s > 0 and s.period_s > 0
        assert sim.load_scene(SCENES_DIR / f"{n}.toml").name == s.name


def test_probe_scene_is_guiatni_5_3():
    s = sim.load_scene("probe_touches_al_steel_wood")
    assert s.kind == "telepresence"
    assert {s.objects[t.body].material for t in s.slave_contacts} == {"aluminium", "carbon_steel", "oak"}
    assert all(t.end_s - t.start_s >= 3.0 for t in s.slave_contacts)
    assert len(s.slave_contacts) >= 6 and 25.0 <= s.duration_s <= 40.0
    # the operator's finger is always on the master pad
    assert len(s.master_contacts) == 1
    assert s.master_contacts[0].start_s == 0.0 and s.master_contacts[0].end_s >= s.duration_s
    # releases between touches
    for a, b in zip(s.slave_contacts, s.slave_contacts[1:]):
        assert b.start_s > a.end_s


def test_virtual_scene_is_yamamoto():
    s = sim.load_scene("virtual_materials")
    assert s.kind == "virtual" and s.rigs == ("master",)
    assert [t.render for t in s.master_contacts] == ["eps", "wood", "ceramic", "brass"]
    with pytest.raises(SceneError, match="scene.kind"):
        sim.build_rig(s, "slave")


def write(tmp_path, text):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    return p


BASE = """
[scene]
kind = "telepresence"
duration_s = 10.0
[objects.al]
material = "aluminium"
thickness_mm = 10.0
[[slave.contacts]]
start_s = 1.0
end_s = 4.0
object = "al"
force_N = 6.0
"""


@pytest.mark.parametrize(
    "mutation, field, expected",
    [
        (("duration_s = 10.0", "duration_s = -1.0"), "scene.duration_s", "a number in"),
        (
            ("duration_s = 10.0", 'duration_s = "ten"'),
            "scene.duration_s",
            "a number in (0, 1000000], got 'ten'",
        ),
        (('kind = "telepresence"', 'kind = "holodeck"'), "scene.kind", "one of telepresence, virtual"),
        (('material = "aluminium"', 'material = "unobtainium"'), "objects.al.material", "a known material"),
        (("thickness_mm = 10.0", "thickness_mm = 0.0"), "objects.al.thickness_mm", "a number in"),
        (('object = "al"', 'object = "cu"'), "slave.contacts[0].object", "one of the scene's objects"),
        (("end_s = 4.0", "end_s = 0.5"), "slave.contacts[0].end_s", "a time after start_s"),
        (("force_N = 6.0", "force_N = 0.0"), "slave.contacts[0].force_N", "a number in"),
        (
            ("[scene]", "[scenery]"),
            "scenery",
            "one of finger, master, noise, numerics, objects, record, scene, slave, tem (an unknown key)",
        ),
        (("[scene]", "[scene]\nname = 3"), "scene.name", "a non-empty string"),
    ],
)
def test_malformed_scene_names_file_field_and_expectation(tmp_path, mutation, field, expected):
    p = write(tmp_path, BASE.replace(*mutation))
    with pytest.raises(SceneError) as ei:
        sim.load_scene(p)
    msg = str(ei.value)
    assert str(p) in msg and f"'{field}'" in msg and expected in msg
    assert isinstance(ei.value, ValueError)


def test_overlapping_contacts_and_bad_toml(tmp_path):
    p = write(
        tmp_path, BASE + '[[slave.contacts]]\nstart_s = 3.0\nend_s = 5.0\nobject = "al"\nforce_N = 6.0\n'
    )
    with pytest.raises(SceneError, match="slave.contacts.*non-overlapping"):
        sim.load_scene(p)
    p = write(tmp_path, "[scene\nduration_s = 1")
    with pytest.raises(SceneError, match="valid TOML"):
        sim.load_scene(p)
    with pytest.raises(SceneError, match="shipped scene"):
        sim.load_scene("no_such_scene")
    with pytest.raises(SceneError, match=r"missing.toml: no such file \(expected a scene file\)"):
        sim.load_scene(tmp_path / "missing.toml")


def test_virtual_scene_refuses_slave_contacts(tmp_path):
    p = write(tmp_path, BASE.replace('kind = "telepresence"', 'kind = "virtual"'))
    with pytest.raises(SceneError, match="slave.contacts"):
        sim.load_scene(p)


def test_tolerance_picks_the_grid(tmp_path):
    base = BASE.replace("duration_s = 10.0", "duration_s = 10.0\nperiod_s = 0.01")
    for tol, preset in ((0.2, "coarse"), (0.05, "default"), (0.01, "fine"), (0.001, "fine")):
        p = write(tmp_path, base + f"\n[numerics]\ntolerance_C = {tol}\n")
        rig = sim.build_rig(sim.load_scene(p), "slave")
        assert any(f"grid '{preset}'" in r for r in rig.pruning_report())
    p = write(tmp_path, base + "\n[numerics]\ntolerance_C = -1\n")
    with pytest.raises(SceneError, match="numerics.tolerance_C"):
        sim.load_scene(p)


@pytest.mark.parametrize(
    "mutation, field",
    [
        (("duration_s = 10.0", "duration_s = 10.0\nduraton = 3"), "scene.duraton"),
        (("thickness_mm = 10.0", "thickness_mm = 10.0\nthickness = 3"), "objects.al.thickness"),
        (("force_N = 6.0", "force_N = 6.0\nforce = 3"), "slave.contacts[0].force"),
    ],
)
def test_unknown_fields_are_refused_not_ignored(tmp_path, mutation, field):
    p = write(tmp_path, BASE.replace(*mutation))
    with pytest.raises(SceneError) as ei:
        sim.load_scene(p)
    assert f"'{field}'" in str(ei.value) and "(an unknown key)" in str(ei.value)
