"""A fast CLI: the light commands import nothing they do not use (no scipy, no matplotlib, no numpy),
checked on the whole run of a fresh ``python -m telethermo ...`` process (argument parsing, bus, EDS,
SDO): its ``sys.modules`` at exit. (``-X importtime`` would miss the modules importlib.import_module
loads, i.e. the chosen subcommand's own module.) The subcommand registry agrees with the modules."""

from __future__ import annotations

import json
import subprocess
import sys
from importlib.metadata import version

import pytest

from telethermo.cli.main import COMMANDS, build_parser

pytestmark = pytest.mark.slow  # starts processes

HEAVY = ("scipy", "matplotlib", "numpy")
# an empty virtual bus: the commands run their whole path (open the bus, parse the EDS, SDO/NMT) and
# give up after the short timeout (exit 1: nobody answers)
EMPTY = ["--bus", "virtual:tt-imports-empty", "--timeout", "0.05"]
LIGHT = [
    (["--help"], 0),
    (["--version"], 0),
    (["get", "--help"], 0),
    (["get", "--list", "master"], 0),
    (["get", *EMPTY, "master", "kp_A_per_C"], 1),
    (["set", *EMPTY, "master", "kp_A_per_C", "1"], 1),
    (["find", *EMPTY], 1),
    (["status", *EMPTY], 1),
    (["nmt", *EMPTY, "preop", "master"], 1),
    (["sdo", *EMPTY, "5", "0x1018:1"], 1),
]


# `python -m telethermo ARGS`, writing the names in sys.modules to a file when the process exits
PROBE = (
    "import atexit, json, runpy, sys\n"
    "out, sys.argv = sys.argv[1], ['telethermo', *sys.argv[2:]]\n"
    "atexit.register(lambda: open(out, 'w').write(json.dumps(sorted(sys.modules))))\n"
    "runpy.run_module('telethermo', run_name='__main__', alter_sys=True)\n"
)


def imported_modules(argv: list[str], expect_rc: int, tmp_path) -> set[str]:
    out = tmp_path / "modules.json"
    proc = subprocess.run(
        [sys.executable, "-c", PROBE, str(out), *argv], capture_output=True, text=True, timeout=60
    )
    assert proc.returncode == expect_rc, proc.stderr[-2000:]
    return set(json.loads(out.read_text()))


@pytest.mark.parametrize("argv,rc", LIGHT, ids=[" ".join(a[:2]) for a, _ in LIGHT])
def test_light_commands_import_no_scipy_matplotlib_numpy(argv, rc, tmp_path):
    mods = imported_modules(argv, rc, tmp_path)
    assert {"telethermo.cli.main", "argparse"} <= mods  # the list is the CLI process's
    heavy = sorted(m for m in mods if m.split(".")[0] in HEAVY)
    assert not heavy, f"telethermo {' '.join(argv)} imported {heavy[:5]}"
    if argv[0] not in ("--help", "--version"):
        assert "canopen" in mods
    else:  # the top-level help imports no subcommand module at all
        assert not any(m.startswith("telethermo.cli.") and m != "telethermo.cli.main" for m in mods)


def test_only_the_chosen_commands_module_is_imported(tmp_path):
    mods = imported_modules(["status", "--help"], 0, tmp_path)
    cli_mods = {m for m in mods if m.startswith("telethermo.cli.")}
    # status shares the SDO plumbing (common) and nothing else of the CLI
    assert cli_mods == {"telethermo.cli.main", "telethermo.cli.status", "telethermo.cli.common"}


def test_version_from_the_installed_distribution():
    out = subprocess.run(
        [sys.executable, "-m", "telethermo", "--version"], capture_output=True, text=True, timeout=30
    )
    assert out.returncode == 0 and out.stdout.strip() == f"telethermo {version('telethermo')}"


def test_registry_agrees_with_the_modules():
    """Each command's module registers exactly the registry's commands, with a run function; the help
    lists every command with the registry's line."""
    for name in COMMANDS:
        parser = build_parser(name)
        sub = next(a for a in parser._actions if a.dest == "command")
        assert set(sub.choices) == set(COMMANDS)
        assert callable(sub.choices[name].get_default("func")), name
    text = build_parser().format_help()
    for name, cmd in COMMANDS.items():
        assert name in text and cmd.help.replace("%%", "%")[:30] in text.replace("\n", " ")


def test_unknown_command_is_one_usage_error(capsys):
    from telethermo.cli.main import main

    with pytest.raises(SystemExit) as e:
        main(["gte", "master", "x"])
    assert e.value.code == 2
    assert "invalid choice: 'gte'" in capsys.readouterr().err
