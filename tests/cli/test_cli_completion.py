"""Shell completion (issue 25, after issue 13): the scripts ask ``telethermo __complete`` at each Tab, so node
names, EDS parameter names, materials and scenes come from the files in force then. Tested as the shells
call it: bash through its completion function with COMP_WORDS/COMP_CWORD and the installed ``telethermo`` on
PATH; zsh and fish the same way where they are installed (skipped, said so, where not)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from telethermo.bus_config import path as bus_path
from telethermo.cli.completion import command_words, complete

BIN = str(Path(sys.executable).parent)  # the venv's bin, where `telethermo` is installed
ENV = {**os.environ, "PATH": BIN + os.pathsep + os.environ.get("PATH", "")}


def bash_complete(cli, line: str) -> list[str]:
    """What bash completes for ``line`` (the last word is the one being completed), one entry a line."""
    code, script, err = cli("completion", "bash")
    assert code == 0, err
    words = line.split(" ")
    probe = (
        script + f"\nCOMP_WORDS=({' '.join(repr(w) for w in words)}); COMP_CWORD={len(words) - 1}\n"
        "_telethermo; printf '%s\\n' \"${COMPREPLY[@]}\"\n"
    )
    p = subprocess.run(["bash", "-c", probe], capture_output=True, text=True, timeout=60, env=ENV)
    assert p.returncode == 0, p.stderr
    return [w for w in p.stdout.split("\n") if w]


def network_with_an_arm(tmp_path) -> Path:
    """The shipped network file plus a third device, written after the completion script was."""
    f = tmp_path / "network.toml"
    text = bus_path("network.toml").read_text()
    text = text.replace('eds = "master.eds"', f'eds = "{bus_path("master.eds")}"')
    text = text.replace('eds = "slave.eds"', f'eds = "{bus_path("slave.eds")}"')
    f.write_text(text + "\n[nodes.arm]\nnode_id = 5\n")
    return f


def needs_bash(test):
    """A test that starts bash: skipped without it, and `slow` (make test-fast starts no process)."""
    return pytest.mark.slow(
        pytest.mark.skipif(shutil.which("bash") is None, reason="no bash on this machine")(test)
    )


@needs_bash
def test_the_script_is_valid_bash(cli, tmp_path):
    code, script, _ = cli("completion", "bash")
    f = tmp_path / "telethermo.bash"
    f.write_text(script)
    assert subprocess.run(["bash", "-n", str(f)], capture_output=True).returncode == 0


@needs_bash
def test_bash_completes_commands_options_nodes_and_scenes(cli):
    assert bash_complete(cli, "telethermo fault") == ["fault-reset"]
    assert "--no-wait" in bash_complete(cli, "telethermo nmt --no")
    assert set(bash_complete(cli, "telethermo nmt start ")) == {"master", "slave", "all"}
    assert bash_complete(cli, "telethermo session --scene probe_") == ["probe_touches_al_steel_wood"]
    assert {"preop", "reset", "reset-comm"} <= set(bash_complete(cli, "telethermo nmt "))
    assert bash_complete(cli, "telethermo completion f") == ["fish"]


@needs_bash
def test_bash_completes_eds_names_materials_and_the_network_files_nodes(cli, tmp_path):
    assert bash_complete(cli, "telethermo get master kp") == ["kp_A_per_C"]
    assert bash_complete(cli, "telethermo set slave T_s") == []  # T_sensor_C, T_sink_C: read-only
    assert bash_complete(cli, "telethermo get slave T_s") == ["T_sensor_C", "T_sink_C"]
    assert bash_complete(cli, "telethermo set master mode te") == ["telepresence"]  # an enumeration's names
    assert "Identity\\ object.Vendor-ID" in bash_complete(cli, "telethermo get master Identity")  # one word
    assert {"wood", "brass", "stainless_steel"} <= set(bash_complete(cli, "telethermo mode render "))
    # a material of another table, read when Tab is pressed
    table = tmp_path / "table.toml"
    table.write_text("[oak]\nbeta = 500.0\n")
    assert bash_complete(cli, f"telethermo mode render --table {table} ") == ["oak"]
    # node names of the network file on the line, written after the script was made
    net = network_with_an_arm(tmp_path)
    assert bash_complete(cli, f"telethermo status --network {net} ") == ["master", "slave", "arm"]
    assert bash_complete(cli, f"telethermo get --network {net} arm ") == []  # no EDS: no names to offer


def test_the_words_come_from_the_real_parser():
    assert {"--timeout", "--network", "--bus"} <= set(command_words("get"))
    assert {"render", "idle", "telepresence"} <= set(command_words("mode"))
    assert complete(["telethermo", "apply-gains", "gains.json", ""], 3) == ["master", "slave"]
    assert complete(["telethermo", "apply-gains", ""], 2) == []  # FILE: the shell's file names


def test_the_hidden_entry_prints_one_candidate_a_line(capsys):
    from telethermo.cli.main import main

    assert main(["__complete", "2", "telethermo", "nmt", "reset-"]) == 0
    assert capsys.readouterr().out == "reset-comm\n"
    assert main(["__complete", "x"]) == 2 and "usage" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("zsh") is None, reason="zsh is not installed on this machine")
def test_zsh_script_loads_and_completes(cli, tmp_path):
    code, script, _ = cli("completion", "zsh")
    f = tmp_path / "_telethermo"
    f.write_text(script)
    probe = (
        f"autoload -U compinit && compinit -u; source {f}; "
        "compadd() { shift; print -l -- ${(P)1}; }; _files() { :; }; "
        "words=(telethermo get master kp); CURRENT=4; _telethermo"
    )
    p = subprocess.run(["zsh", "-c", probe], capture_output=True, text=True, timeout=60, env=ENV)
    assert p.stdout.split() == ["kp_A_per_C"], p.stderr


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("fish") is None, reason="fish is not installed on this machine")
def test_fish_script_loads_and_completes(cli, tmp_path):
    code, script, _ = cli("completion", "fish")
    f = tmp_path / "telethermo.fish"
    f.write_text(script)
    p = subprocess.run(
        ["fish", "-c", f"source {f}; complete -C 'telethermo get master kp'"],
        capture_output=True,
        text=True,
        timeout=60,
        env=ENV,
    )
    assert p.stdout.split() == ["kp_A_per_C"], p.stderr


def test_the_scene_names_are_the_simulators():
    from telethermo.cli.completion import shipped_scenes
    from telethermo.sim.scene import shipped_scenes as simulators

    assert shipped_scenes() == simulators() and "probe_touches_al_steel_wood" in shipped_scenes()
