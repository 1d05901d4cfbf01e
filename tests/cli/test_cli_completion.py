"""``telethermo completion bash``: a script bash accepts, made from the real parsers, that completes
commands, a command's options, node names and shipped scene names (issue 13: no shell completion)."""
from __future__ import annotations

import shutil
import subprocess

import pytest

from telethermo.cli.completion import command_words

pytestmark = pytest.mark.skipif(shutil.which("bash") is None, reason="no bash on this machine")


def complete(cli, line: str) -> list[str]:
    """What bash completes for ``line`` (the last word is the one being completed)."""
    code, script, err = cli("completion", "bash")
    assert code == 0, err
    words = line.split(" ")
    probe = (script + f"\nCOMP_WORDS=({' '.join(repr(w) for w in words)}); COMP_CWORD={len(words) - 1}\n"
             "_telethermo; printf '%s\\n' \"${COMPREPLY[@]}\"\n")
    p = subprocess.run(["bash", "-c", probe], capture_output=True, text=True, timeout=30)
    assert p.returncode == 0, p.stderr
    return p.stdout.split()


@pytest.mark.slow  # starts bash
def test_the_script_is_valid_bash(cli, tmp_path):
    code, script, _ = cli("completion", "bash")
    f = tmp_path / "telethermo.bash"
    f.write_text(script)
    assert subprocess.run(["bash", "-n", str(f)], capture_output=True).returncode == 0


@pytest.mark.slow  # starts bash
def test_it_completes_commands_options_nodes_and_scenes(cli):
    assert complete(cli, "telethermo fault") == ["fault-reset"]
    assert "--no-wait" in complete(cli, "telethermo nmt --no")
    assert set(complete(cli, "telethermo nmt start ")) >= {"master", "slave", "all"}
    assert complete(cli, "telethermo session --scene probe_") == ["probe_touches_al_steel_wood"]
    assert {"preop", "reset", "reset-comm"} <= set(complete(cli, "telethermo nmt "))


def test_the_words_come_from_the_real_parser():
    assert {"--timeout", "--network", "--bus"} <= set(command_words("get"))
    assert {"render", "idle", "telepresence"} <= set(command_words("mode"))
