"""Issue 25: what the node programs say to a new user: --help tells the real --model default and the exit
codes Ctrl-C really gives (0); a damaged EDS is a bad file (exit 2, its line), not a failed start (1).
The console programs run as processes."""

from __future__ import annotations

import subprocess
import sys

import pytest

from telethermo.bus_config import path as bc

pytestmark = pytest.mark.slow  # starts processes


def node(role: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", f"telethermo.nodes.{role}", *args], capture_output=True, text=True, timeout=120
    )


def test_help_tells_the_model_default_and_the_exit_codes():
    p = node("master", "--help")
    text = " ".join(p.stdout.split())
    assert p.returncode == 0
    assert (
        "--model MODEL identified model file (default: none; the flux estimator, the default, needs none"
        in text
    )
    assert "sim_tem.json" not in text and "130" not in text
    assert (
        "exit codes: 0 ok (also a stop by SIGINT/SIGTERM, Ctrl-C), 1 runtime failure, 2 bad option or file"
        in text
    )


def test_a_damaged_eds_exits_2_naming_the_file_and_line(tmp_path):
    eds = tmp_path / "master.eds"
    text = bc("master.eds").read_text()
    eds.write_text(text[: text.index("\n[", 3000) + 4])  # cut in the middle of a section header
    net = tmp_path / "network.toml"
    net.write_text(
        f'[nodes.master]\nnode_id = 1\neds = "{eds}"\n[nodes.slave]\nnode_id = 2\neds = "{bc("slave.eds")}"\n'
    )
    p = node(
        "master",
        "--network",
        str(net),
        "--scene",
        "probe_touches_al_steel_wood",
        "--bus",
        "virtual:tt-eds",
        "--cycles",
        "5",
    )
    assert p.returncode == 2, p.stderr
    lines = p.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"telethermo-master: error: {eds}: not an INI/EDS file ")
    assert "[line " in lines[0] and "Traceback" not in p.stderr
