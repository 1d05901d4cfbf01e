"""Issue 25: a scene file cut short right after its [master] header ran silently (the finger never on the
display). It is refused with the file and the field, as a node program and `telethermo session` see it."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from telethermo import sim

SCENE = Path(__file__).resolve().parents[2] / "sim" / "scenes" / "probe_touches_al_steel_wood.toml"


def cut_after_master(tmp_path: Path) -> Path:
    text = SCENE.read_text()
    p = tmp_path / "cut.toml"
    p.write_text(text[: text.index("[master]") + len("[master]\n")])
    return p


def test_a_scene_cut_after_its_master_header_is_refused(tmp_path):
    p = cut_after_master(tmp_path)
    with pytest.raises(ValueError) as exc:
        sim.load_scene(p)
    assert str(exc.value) == (
        f"{p}: field 'master': expected contacts ([[master.contacts]]) or start under "
        "[master] (an empty [master] table: is the file cut short?)"
    )


@pytest.mark.slow
def test_the_session_command_refuses_it_with_exit_2(tmp_path):
    p = cut_after_master(tmp_path)
    r = subprocess.run(
        [sys.executable, "-m", "telethermo", "session", "--scene", str(p), "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 2 and r.stderr.count("\n") == 1
    assert r.stderr.startswith(f"telethermo session: error: {p}: field 'master': expected contacts"), r.stderr
