"""A node program on python-can's in-process ``virtual`` bus (no --bus, no hub published: network.toml's
``virtual:telethermo``) waited forever for a peer no other process can reach, saying only "ready on
virtual:telethermo". It now says so on stderr in one warning line naming what to do (a hub, or --bus), and
still runs (a test may use it beside in-process devices). Run in this process (the master, one cycle) and as
the real program (the slave, which waits for a SYNC until stopped)."""

from __future__ import annotations

import logging
import os
import signal
import subprocess
from pathlib import Path

import pytest

from telethermo.control.types import Role
from telethermo.nodes.launch import node_command, stop_process, wait_for
from telethermo.nodes.main import run_node
from tests.support.busenv import isolate_bus_settings

SCENES = Path(__file__).resolve().parents[2] / "sim" / "scenes"
SCENE = SCENES / "free_pad_identification.toml"


@pytest.fixture
def no_bus_setting(tmp_path, monkeypatch):
    """No --bus, CAN_* variable, python-can config file or published hub: network.toml's virtual bus."""
    isolate_bus_settings(tmp_path, monkeypatch)


@pytest.fixture
def restore_process_state():
    """run_node sets up the root logger (force=True) and the SIGINT/SIGTERM handlers: give them back."""
    root = logging.getLogger()
    handlers, level = root.handlers[:], root.level
    sigs = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    yield
    root.handlers[:] = handlers
    root.setLevel(level)
    for s, h in sigs.items():
        signal.signal(s, h)


def warnings_in(err: str) -> list[str]:
    return [ln for ln in err.splitlines() if ln.startswith("telethermo-") and ": warning: " in ln]


def test_the_node_program_warns_in_one_line_on_the_in_process_bus(
    no_bus_setting, restore_process_state, capsys
):
    code = run_node(Role.MASTER, ["--scene", str(SCENE), "--cycles", "1", "--wait-peer", "0"])
    err = capsys.readouterr().err
    assert code == 0, err
    [line] = warnings_in(err)
    assert line.startswith("telethermo-master: warning: virtual:telethermo (from ") and "network.toml" in line
    assert "inside this process only" in line and "telethermo-hub" in line and "--bus socketcan:can0" in line
    assert "node 1 ready on virtual:telethermo" in err and "Traceback" not in err


def test_a_named_virtual_bus_is_warned_about_too(restore_process_state, capsys):
    argv = ["--bus", "virtual:tt-warn", "--scene", str(SCENE), "--cycles", "1", "--wait-peer", "0"]
    assert run_node(Role.MASTER, argv) == 0
    [line] = warnings_in(capsys.readouterr().err)
    assert line.startswith("telethermo-master: warning: virtual:tt-warn (from --bus) is a bus inside")


@pytest.mark.slow
def test_the_slave_process_says_it_instead_of_waiting_silently(no_bus_setting, tmp_path):
    err_path = tmp_path / "slave-stderr.log"
    with open(err_path, "wb") as err:
        proc = subprocess.Popen(
            node_command("slave", "--scene", str(SCENES / "pads_in_air.toml")),
            stdout=subprocess.DEVNULL,
            stderr=err,
            env=dict(os.environ),
            start_new_session=True,
        )
    try:
        assert wait_for(lambda: warnings_in(err_path.read_text()), 60), err_path.read_text()
    finally:
        stop_process(proc)
    text = err_path.read_text()
    assert "node 2 ready on virtual:telethermo, waiting for the master's SYNC" in text
    [line] = warnings_in(text)
    assert (
        line.startswith("telethermo-slave: warning: virtual:telethermo (from ") and "telethermo-hub" in line
    )
