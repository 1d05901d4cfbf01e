"""Damaged EDS files are refused in one line naming the file and what is wrong (issue 13): a file that is
not INI, an empty file, and a truncated one (cut mid-line, and cut at a line boundary so that it still parses
but the objects its lists name have no section). Checked on the parser, through the operator CLI (exit 2,
one line, no traceback) and through a node program (it refuses to start, naming the file)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from telethermo.bus_config import path as eds_path
from telethermo.cli.main import EXIT_USAGE, main
from telethermo.device.eds_info import EdsError, EdsInfo

ROOT = Path(__file__).resolve().parents[2]
MASTER = eds_path("master.eds").read_text(encoding="ascii")


def damaged(tmp_path: Path) -> dict[str, tuple[Path, str]]:
    """name -> (file, the words its error must contain)."""
    lines = MASTER.splitlines(keepends=True)
    files = {
        "not_ini": ("[FileInfo]\nFileName=x\n[1000\nParameterName=Device type\n", "not an INI/EDS file"),
        "empty": ("", "not an EDS file (an empty file"),
        # cut inside a section header about a third of the way in (an unterminated "[1A" line)
        "cut_mid_line": (MASTER[: MASTER.index("\n[", len(MASTER) // 3) + 4], "not an INI/EDS file"),
        "cut_at_a_line": ("".join(lines[: len(lines) // 3]), "listed object(s) have no section"),
        "no_object_lists": ("[FileInfo]\nFileName=x.eds\n", "no [MandatoryObjects] section"),
    }
    out = {}
    for name, (text, words) in files.items():
        p = tmp_path / f"{name}.eds"
        p.write_text(text, encoding="ascii")
        out[name] = (p, words)
    return out


def test_the_shipped_files_pass():
    for role in ("master", "slave"):
        assert EdsInfo(eds_path(f"{role}.eds")).get("T_sensor_C").index == 0x2000


@pytest.mark.parametrize("name", ["not_ini", "empty", "cut_mid_line", "cut_at_a_line", "no_object_lists"])
def test_the_parser_names_the_file_and_the_damage_in_one_line(tmp_path, name):
    path, words = damaged(tmp_path)[name]
    with pytest.raises(EdsError) as exc:
        EdsInfo(path)
    text = str(exc.value)
    assert str(path) in text and words in text and "\n" not in text, text


def _network(tmp_path: Path, eds: Path) -> Path:
    net = eds_path("network.toml").read_text(encoding="utf-8")
    net = net.replace('eds = "master.eds"', f'eds = "{eds}"').replace(
        'eds = "slave.eds"', f'eds = "{eds_path("slave.eds")}"'
    )
    p = tmp_path / "network.toml"
    p.write_text(net, encoding="utf-8")
    return p


@pytest.mark.parametrize("name", ["not_ini", "empty", "cut_at_a_line"])
def test_the_cli_refuses_a_damaged_eds_in_one_line(tmp_path, capsys, name):
    path, words = damaged(tmp_path)[name]
    code = main(
        [
            "get",
            "master",
            "T_sensor_C",
            "--network",
            str(_network(tmp_path, path)),
            "--bus",
            "virtual:tt-eds",
            "--timeout",
            "0.2",
        ]
    )
    err = capsys.readouterr().err.strip()
    assert code == EXIT_USAGE and len(err.splitlines()) == 1 and words in err and str(path) in err, err


@pytest.mark.slow
def test_a_node_refuses_to_start_on_a_truncated_eds(tmp_path):
    path, words = damaged(tmp_path)["cut_at_a_line"]
    p = subprocess.run(
        [
            sys.executable,
            "-m",
            "telethermo.nodes.master",
            "--network",
            str(_network(tmp_path, path)),
            "--bus",
            "virtual:tt-eds-node",
            "--scene",
            str(ROOT / "sim/scenes/pads_in_air.toml"),
            "--cycles",
            "3",
        ],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
    )
    assert (
        p.returncode != 0 and words in p.stderr and str(path) in p.stderr and "Traceback" not in p.stderr
    ), p.stderr
