"""Issue 25: ``telethermo session`` run while a user's ``telethermo-hub`` is up (e.g. ``make demo`` beside a
lab's hub) must not replace the hub's published address nor delete it on exit. Real processes: the hub
program (publishing) and the session command, sharing one runtime dir."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from telethermo.nodes.launch import HubProcess
from telethermo.transport.published import publish_if_absent, running, state_file, unpublish

pytestmark = pytest.mark.slow  # starts processes

SCENE = Path(__file__).resolve().parents[2] / "sim" / "scenes" / "probe_touches_al_steel_wood.toml"


def test_session_leaves_a_running_hub_published(tmp_path, monkeypatch):
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(run_dir))  # the hub child inherits it
    hub = HubProcess(publish=True, log_path=tmp_path / "user-hub.log")
    hub.start()
    try:
        before = running()
        assert before is not None and before.pid == hub.proc.pid and before.by == "telethermo-hub"
        p = subprocess.run(
            [
                sys.executable,
                "-c",
                "import sys; from telethermo.cli.main import main; sys.exit(main())",
                "session",
                "--scene",
                str(SCENE),
                "--out",
                str(tmp_path / "s"),
                "--duration",
                "0.3",
                "--quiet",
                "--no-plot",
            ],
            capture_output=True,
            text=True,
            timeout=300,
            env=dict(os.environ),
        )
        assert p.returncode == 0, p.stderr
        line = (
            f"telethermo session: telethermo-hub (pid {hub.proc.pid}) stays the bus other terminals find "
            f"({hub.bus}); this session's nodes: --bus socketcand://127.0.0.1:"
        )
        assert line in p.stderr
        after = running()  # the user's hub is still the one found, with its own file
        assert after is not None and (after.pid, after.bus, after.by) == (
            hub.proc.pid,
            hub.bus,
            "telethermo-hub",
        )
        assert json.loads(state_file().read_text())["pid"] == hub.proc.pid
        # the session's nodes ran on a hub of their own (its log in the session's folder), not on the user's
        own = p.stderr.split("this session's nodes: --bus ", 1)[1].split()[0]
        assert own != hub.bus and "telethermo-hub stopped" in (tmp_path / "s" / "hub.log").read_text()
    finally:
        hub.stop()
    assert running() is None


def test_publish_if_absent_keeps_a_live_writer_and_replaces_a_stale_one(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    # a stale file (its writer gone) is replaced
    state_file().parent.mkdir(parents=True)
    state_file().write_text(
        json.dumps({"bus": "socketcand://127.0.0.1:1/telethermo", "pid": dead.pid, "by": "telethermo-hub"})
    )
    assert publish_if_absent("socketcand://127.0.0.1:2/telethermo", "telethermo session") is None
    assert running().bus == "socketcand://127.0.0.1:2/telethermo"
    # a live writer's file is kept, and named
    other = publish_if_absent("socketcand://127.0.0.1:3/telethermo", "telethermo session", pid=os.getppid())
    assert other is not None and other.bus == "socketcand://127.0.0.1:2/telethermo"
    assert running().bus == "socketcand://127.0.0.1:2/telethermo"
    # unpublish removes only what this pid wrote
    unpublish(pid=os.getppid())
    assert running() is not None
    unpublish()
    assert running() is None
    assert [p.name for p in state_file().parent.iterdir()] == []  # no temporary file left behind
