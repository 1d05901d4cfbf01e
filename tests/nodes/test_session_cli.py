"""``telethermo session`` as a user runs it (a real process): figures equal the offline runner's,
bad input is refused with exit 2, Ctrl-C stops every child cleanly (exit 130, figures of what ran)."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from telethermo.nodes.launch import wait_for
from telethermo.offline import run_offline_session
from telethermo.recording.result import SessionRun
from telethermo.transport.bus import open_bus, parse_bus_string

pytestmark = pytest.mark.slow  # starts processes

SCENE = Path(__file__).resolve().parents[2] / "sim" / "scenes" / "probe_touches_al_steel_wood.toml"


def syncs_seen(bus_text: str, n: int, timeout_s: float) -> int:
    """SYNC frames (COB-ID 0x080) that a client of the bus ``bus_text`` sees, counted up to ``n`` or for at
    most ``timeout_s`` s."""
    bus = open_bus(parse_bus_string(bus_text))
    try:
        seen, deadline = 0, time.monotonic() + timeout_s
        while seen < n and time.monotonic() < deadline:
            msg = bus.recv(0.2)
            seen += msg is not None and msg.arbitration_id == 0x080
        return seen
    finally:
        bus.shutdown()


def session(*args: str, **kw) -> subprocess.Popen:
    # the console script's entry point (``python -m telethermo.cli.main`` would import main twice);
    # a runtime dir of its own, so that the bus the session publishes never redirects this user's commands
    import os
    import tempfile

    kw.setdefault("env", dict(os.environ, XDG_RUNTIME_DIR=tempfile.mkdtemp(prefix="tt-session-run-")))
    return subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys; from telethermo.cli.main import main; sys.exit(main())",
            "session",
            *args,
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **kw,
    )


def processes_mentioning(text: str) -> list[int]:
    pids = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                if text in (d / "cmdline").read_bytes().decode(errors="replace"):
                    pids.append(int(d.name))
            except OSError:
                pass
    return pids


def test_session_figures_equal_offline(tmp_path):
    p = session("--scene", str(SCENE), "--out", str(tmp_path), "--duration", "2.5", "--quiet")
    out, err = p.communicate(timeout=300)
    assert p.returncode == 0, err
    fig = json.loads((tmp_path / "summary.json").read_text())
    off = run_offline_session(SCENE, duration_s=2.5, rounding="real32", seed=0).figures
    assert fig["n_steps"] == off["n_steps"] == 250
    assert fig["transparency"]["per_contact"] == off["transparency"]["per_contact"]
    assert fig["tracking"] == off["tracking"]
    assert fig["run"]["complete"] and fig["run"]["master"]["lockstep_timeouts"] == 0
    run = SessionRun.from_dict(fig["run"])  # the typed run block round-trips the summary's JSON
    assert run.master is not None and run.master.cycles == run.cycles_requested == 250
    assert json.dumps(run.to_dict()) == json.dumps(fig["run"])
    assert run.master.io_rig is None and "module_restarts" not in fig["run"]["master"]  # a simulated rig
    for name in ("recording.csv", "session.png", "master.csv", "slave.csv", "master.log", "slave.log"):
        assert (tmp_path / name).stat().st_size > 0, name
    assert "transparency" in out and "aluminium" in out


@pytest.mark.parametrize(
    "args, fragment",
    [
        (["--scene", "no/such/scene.toml"], "no/such/scene.toml"),
        (["--scene", str(SCENE), "--duration", "-1"], "--duration"),
        (["--scene", str(SCENE), "--bus", "vcan0"], "INTERFACE:CHANNEL"),
        (["--scene", str(SCENE), "-i", "kvasr", "-c", "0"], "unknown python-can interface 'kvasr'"),
        (
            ["--scene", str(SCENE), "-i", "virtual", "-c", "x"],
            "virtual:x (from -i/-c/-b) exists inside one process only",
        ),
    ],
)
def test_bad_input_exit_2(tmp_path, args, fragment):
    p = session(*args, "--out", str(tmp_path))
    _, err = p.communicate(timeout=120)
    assert p.returncode == 2 and fragment in err


@pytest.mark.parametrize(
    "text, reason",
    [
        ("t_s,T_C\n0.0,22.0\n", "line 1 column 1: not valid JSON"),  # a recording given by mistake
        ('{"format": "telethermo-tem-model", "format_version": true}', "field 'format_version': expected 1"),
    ],
)
def test_a_bad_model_file_is_refused_before_any_node_starts(tmp_path, text, reason):
    """--model is read here as the nodes read it (telethermo.ident.load_model), as --gains and
    --material-lab are: one line naming the file and the reason, exit 2, no node started (it was
    "the slave process ended (exit 2)", the reason only in slave.log)."""
    bad = tmp_path / "rec_garbage.csv"
    bad.write_text(text)
    out = tmp_path / "out"
    p = session("--scene", str(SCENE), "--out", str(out), "--model", str(bad))
    _, err = p.communicate(timeout=120)
    assert p.returncode == 2, err
    assert len(err.splitlines()) == 1, err
    assert err.startswith(f"telethermo session: error: --model: model file {bad}: {reason}"), err
    assert "Traceback" not in err and not (out / "slave.log").exists() and not (out / "master.log").exists()


def test_ctrl_c_stops_everything_cleanly(tmp_path):
    import os

    run_dir = tmp_path / "run"  # the session publishes its bus there (XDG_RUNTIME_DIR), removes it at the end
    run_dir.mkdir()
    state = run_dir / "telethermo" / "hub.json"
    p = session(
        "--scene",
        str(SCENE),
        "--out",
        str(tmp_path),
        "--timing",
        "realtime",
        "--quiet",
        "--no-plot",
        env=dict(os.environ, XDG_RUNTIME_DIR=str(run_dir)),
    )
    try:
        assert wait_for(
            lambda: (
                (tmp_path / "master.log").exists() and "OPERATIONAL" in (tmp_path / "master.log").read_text()
            ),
            120,
        )
        doc = json.loads(state.read_text())
        assert doc["pid"] == p.pid and doc["by"] == "telethermo session"
        assert doc["bus"].startswith("socketcand://127.0.0.1:") and doc["bus"].endswith("/telethermo")

        # a second terminal's command finds the session's nodes with no bus flag
        # (the master reports OPERATIONAL before the slave's SDO server may answer: ask until it does)
        def get_slave():
            return subprocess.run(
                [sys.executable, "-m", "telethermo", "get", "slave", "Manufacturer device name"],
                capture_output=True,
                text=True,
                timeout=60,
                env=dict(os.environ, XDG_RUNTIME_DIR=str(run_dir)),
            )

        answers = []
        assert wait_for(lambda: answers.append(get_slave()) or answers[-1].returncode == 0, 60), answers[
            -1
        ].stderr
        assert answers[-1].stderr == "", answers[-1].stderr
        # let it run a while: 100 SYNC cycles seen on its bus (1 s at 100 Hz); what ran must be reported
        assert syncs_seen(doc["bus"], 100, 60) == 100, "the session's pair does not run its SYNC cycles"
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=120)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == 130, err
    assert processes_mentioning(str(tmp_path)) == []  # hub, master and slave are gone
    assert not state.exists()  # and the published bus with them
    assert "stopped (SIGTERM)" in (tmp_path / "slave.log").read_text()
    assert "stopped (SIGTERM)" in (tmp_path / "master.log").read_text()
    fig = json.loads((tmp_path / "summary.json").read_text())  # the figures of what ran
    assert 0 < fig["n_steps"] < 3000 and fig["run"]["complete"] is False
