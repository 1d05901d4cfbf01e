"""The scene's settled starts (issue 11): the display renders air for long before t = 0 (the finger at its
natural temperature), the probe's pad held at a temperature; bad values named in one line."""

import dataclasses

import numpy as np
import pytest

from telethermo import sim
from telethermo.sim.compile import finger_natural_C
from telethermo.sim.errors import SceneError


@pytest.fixture(scope="module")
def scene():
    return sim.load_scene("probe_touches_al_steel_wood")


def test_finger_start_is_the_natural_finger(scene):
    """The finger on the settled display has exactly the profile of the finger in air (direct touch at t = 0),
    and the pad draws from it what air would: h·A·(T_skin − T_air)."""
    rig = sim.build_rig(scene, "master", noise=False)
    ref = sim.build_reference(scene)
    body = rig.cfg.body
    base = 3 + rig.sensor.n
    np.testing.assert_allclose(rig.x[base : base + body.n], ref.finger.x[: ref.finger.n], atol=1e-9)
    tr = rig.truth()
    assert tr.T_surface_C == pytest.approx(ref.T_contact_C, abs=1e-9)
    air_loss_W = rig.params.h_air_W_m2K * rig.params.area_m2 * (ref.T_contact_C - scene.ambient_C)
    assert tr.Q_into_body_W == pytest.approx(-air_loss_W, abs=1e-9)
    # a steady state: held at that current for 5 s, nothing moves
    I0 = rig.I
    for _ in range(500):
        rig.apply_current(I0)
        rig.advance(0.01)
    assert rig.truth().T_surface_C == pytest.approx(ref.T_contact_C, abs=1e-6)


def test_slave_start_holds_the_pad_at_the_finger_temperature(scene):
    rig = sim.build_rig(scene, "slave", noise=False)
    T_nat = finger_natural_C(scene, rig.params, rig.grid)
    assert rig.truth().T_sensor_true_C == pytest.approx(T_nat, abs=1e-9)
    assert rig.read().current_A == rig.I and rig.I > 0  # heating: the pad sits above the 25 °C air
    plain = sim.build_rig(dataclasses.replace(scene, slave_start=None), "slave", noise=False)
    assert plain.truth().T_sensor_true_C == pytest.approx(scene.ambient_C, abs=1e-9) and plain.I == 0.0


def _scene_text(start_line: str, section: str = "master") -> str:
    return f"""
[scene]
name = "t"
kind = "telepresence"
duration_s = 2.0
period_s = 0.01
ambient_C = 25.0
[objects.al]
material = "aluminium"
thickness_mm = 5.0
[{section}]
{start_line}
[[master.contacts]]
start_s = 0.0
end_s = 2.0
force_N = 8.0
"""


@pytest.mark.parametrize(
    "line,section,field",
    [
        ('start = "warm"', "master", "master.start"),
        ("start = 50.0", "master", "master.start"),
        ("start = true", "slave", "slave.start"),
    ],
)
def test_bad_start_is_one_named_error(tmp_path, line, section, field):
    p = tmp_path / "s.toml"
    p.write_text(_scene_text(line, section))
    with pytest.raises(SceneError) as ei:
        sim.load_scene(p)
    assert field in str(ei.value) and str(p) in str(ei.value)
