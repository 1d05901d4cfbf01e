"""The node programs' command line: a scene by file or by the name of a shipped scene (as ``telethermo
session`` takes it), and one named line for a scene that is neither (issue 13)."""

from __future__ import annotations

import pytest

from telethermo.control.types import Role
from telethermo.nodes.options import OptionError, build_parser, options_from_args
from telethermo.sim.scene import SCENES_DIR


def parse(argv: list[str]):
    return options_from_args(Role.MASTER, build_parser(Role.MASTER).parse_args(argv))


def test_a_shipped_scene_by_name_or_by_file():
    by_name = parse(["--bus", "virtual:x", "--scene", "pads_in_air"])
    by_file = parse(["--bus", "virtual:x", "--scene", str(SCENES_DIR / "pads_in_air.toml")])
    assert by_name.scene == by_file.scene == SCENES_DIR / "pads_in_air.toml"


@pytest.mark.parametrize(
    "scene, message",
    [
        (
            "no_such_scene",
            r"--scene 'no_such_scene': .*expected a scene file or a shipped scene \(.*pads_in_air",
        ),
        ("/tmp/tt-no-such-scene.toml", r"--scene '/tmp/tt-no-such-scene.toml': no such file"),
    ],
)
def test_an_unknown_scene_is_one_named_line(scene, message):
    with pytest.raises(OptionError, match=message):
        parse(["--bus", "virtual:x", "--scene", scene])
