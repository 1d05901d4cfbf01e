"""The curses view in a real terminal: `telethermo monitor --replay` inside tmux, the screen
captured as a person would see it, and the keys (filter, pause, quit) pressed."""

from __future__ import annotations

import os
import shutil
import struct
import subprocess
import sys
import time
from pathlib import Path

import can
import pytest

from telethermo.nodes.launch import wait_for

pytestmark = [
    pytest.mark.skipif(shutil.which("tmux") is None, reason="tmux is not installed"),
    pytest.mark.slow,
]
ROOT = Path(__file__).resolve().parents[2]


def _log(path: Path) -> None:
    w = can.Logger(str(path))
    t = 1_700_000_000.0
    frames = [
        (0.0, 0x701, [0x00]),
        (0.001, 0x701, [0x7F]),
        (0.002, 0x702, [0x00]),
        (0.003, 0x702, [0x7F]),
        (0.010, 0x000, [0x01, 0x00]),
    ]
    for k in range(1, 60):
        tk = 0.02 + 0.01 * k
        frames += [
            (tk, 0x080, [k]),
            (tk + 0.001, 0x181, struct.pack("<ff", 30.0 + 0.01 * k, -0.5)),
            (tk + 0.002, 0x182, struct.pack("<ff", 24.0, 0.5)),
        ]
        if k % 10 == 0:
            frames += [(tk + 0.003, 0x701, [0x05]), (tk + 0.004, 0x702, [0x05])]
    frames += [
        (0.70, 0x082, struct.pack("<HB5s", 0x4210, 0x08, b"\x00" * 5)),
        (0.71, 0x601, struct.pack("<BHBf", 0x23, 0x2401, 0, 60.0)),
        (0.711, 0x581, struct.pack("<BHBL", 0x80, 0x2401, 0, 0x06090031)),
    ]
    for dt, cob, data in sorted(frames):
        w.on_message_received(
            can.Message(timestamp=t + dt, arbitration_id=cob, data=bytes(data), is_extended_id=False)
        )
    w.stop()


def _capture(sock: str) -> str:
    return subprocess.run(
        ["tmux", "-L", sock, "capture-pane", "-p", "-t", "mon"], capture_output=True, text=True, check=True
    ).stdout


def keys(sock: str, *names: str) -> None:
    subprocess.run(["tmux", "-L", sock, "send-keys", "-t", "mon", *names], check=True)


def _wait_screen(sock: str, text: str, timeout_s: float = 20.0) -> str:
    """The screen once ``text`` is on it and the terminal has finished drawing: two captures 0.1 s apart
    agree (curses sends a redraw in pieces; under load a capture between them showed half a title line).
    A screen that keeps changing until the deadline is returned as last seen with ``text`` on it."""
    deadline = time.monotonic() + timeout_s
    screen, prev = "", None
    while time.monotonic() < deadline:
        screen = _capture(sock)
        if text in screen and screen == prev:
            return screen
        prev = screen if text in screen else None
        time.sleep(0.1)
    if text in screen:
        return screen
    raise AssertionError(f"{text!r} never appeared on the screen:\n{screen}")


def test_view_in_a_real_terminal(tmp_path):
    log = tmp_path / "t.log"
    _log(log)
    sock = f"tt-test-{time.monotonic_ns()}"
    done = tmp_path / "rc"
    cmd = (
        f"{sys.executable} -m telethermo.cli.main monitor --replay {log} --speed 0; "
        f"echo $? > {done}; sleep 30"
    )
    # curses believes LINES/COLUMNS over the terminal's real size: do not pass on the test runner's
    env = {k: v for k, v in os.environ.items() if k not in ("LINES", "COLUMNS")}
    subprocess.run(
        ["tmux", "-L", sock, "new-session", "-d", "-s", "mon", "-x", "140", "-y", "40", "-c", str(ROOT), cmd],
        check=True,
        env=env,
    )
    try:
        screen = _wait_screen(sock, "[END OF LOG]")
        assert "1 master   OPERATIONAL" in screen and "2 slave    OPERATIONAL" in screen
        assert "estimate_C=30.590 degC" in screen  # the last master TPDO1, by the EDS mapping
        assert "SYNC 10.00 ms" in screen and "#59" in screen
        assert "0x4210 Device temperature" in screen
        assert "T_max_C ABORT 0x06090031 Value of parameter written too high" in screen
        assert screen.splitlines()[-1].startswith("[?] help")
        subprocess.run(["tmux", "-L", sock, "send-keys", "-t", "mon", "f"], check=True)
        _wait_screen(sock, "filter (text, node=N")
        subprocess.run(["tmux", "-L", sock, "send-keys", "-t", "mon", "emcy", "Enter"], check=True)
        screen = _wait_screen(sock, "EVENTS (filter: emcy)")
        events = screen.split("EVENTS (filter: emcy)")[1]
        assert "EMCY 0x4210" in events and "boot-up" not in events and "ABORT" not in events
        keys(sock, "?")
        screen = _wait_screen(sock, "HELP: keys of telethermo monitor")
        assert "raw frame list: one row per COB-ID" in screen and "PgUp/PgDn" in screen
        keys(sock, "r")
        screen = _wait_screen(sock, "RAW FRAME LIST")
        sync_row = next(ln for ln in screen.splitlines() if ln.startswith("     080"))
        assert sync_row.split()[1:4] == ["SYNC", "-", "59"] and "10.00" in sync_row
        keys(sock, "l")
        _wait_screen(sock, "FRAME LOG (last 2000 frames kept)")
        keys(sock, "Home")
        screen = _wait_screen(sock, "newer below (End to follow)")
        assert "boot-up node 1" in screen  # the first frame of the log, scrolled back to
        keys(sock, "End")
        screen = _wait_screen(sock, "0x581")  # the newest frame again
        assert "newer below" not in screen
        keys(sock, "t")
        screen = _wait_screen(sock, "TEMPERATURES (strip chart")
        assert "master TPDO1 estimate_C = 30.590 degC" in screen and "|*" in screen
        keys(sock, "m")
        _wait_screen(sock, "CHECK FIRST")
        subprocess.run(["tmux", "-L", sock, "send-keys", "-t", "mon", "p"], check=True)
        _wait_screen(sock, "[PAUSED]")
        subprocess.run(["tmux", "-L", sock, "send-keys", "-t", "mon", "q"], check=True)
        assert wait_for(done.exists, 30, poll_s=0.1), "the monitor did not exit"
        assert done.read_text().strip() == "0"
    finally:
        subprocess.run(["tmux", "-L", sock, "kill-server"], capture_output=True)


def test_damaged_log_keeps_the_decoded_screen_and_says_where(tmp_path):
    """A damaged row stops the replay; the view keeps what it decoded and names the file and line;
    quitting exits 2 (a damaged file is bad input, as in `plot`; issue 25) with the same line on stderr."""
    rows = [
        "t_s,cob_id,kind,node,dlc,data,text,fields",
        "0.000000,0x701,HEARTBEAT,1,1,05,,{}",
        "0.001000,0x702,HEARTBEAT,2,1,05,,{}",
    ]
    rows += [f"{0.01 * k:.6f},0x080,SYNC,,1,{k:02x},,{{}}" for k in range(1, 30)]
    rows += ["0.300000,0x080,SYNC,,1,zz,,{}"]  # line 33: not hex
    rows += [f"{0.31 + 0.01 * k:.6f},0x080,SYNC,,1,{k:02x},,{{}}" for k in range(1, 5)]
    log = tmp_path / "bad.csv"
    log.write_text("\n".join(rows) + "\n")
    sock = f"tt-test-{time.monotonic_ns()}"
    done, err = tmp_path / "rc", tmp_path / "err"
    cmd = (
        f"{sys.executable} -m telethermo.cli.main monitor --replay {log} --speed 0 2> {err}; "
        f"echo $? > {done}; sleep 30"
    )
    env = {k: v for k, v in os.environ.items() if k not in ("LINES", "COLUMNS")}
    subprocess.run(
        ["tmux", "-L", sock, "new-session", "-d", "-s", "mon", "-x", "200", "-y", "40", "-c", str(ROOT), cmd],
        check=True,
        env=env,
    )
    try:
        screen = _wait_screen(sock, f"LOG DAMAGED, replay stopped: {log}:33: damaged row")
        assert f"{log}:33: damaged row" in screen and "[END OF LOG]" not in screen
        assert "1 master   OPERATIONAL" in screen and "#29" in screen  # what was decoded stays
        keys(sock, "q")
        assert wait_for(done.exists, 30, poll_s=0.1), "the monitor did not exit"
        assert done.read_text().strip() == "2"
        assert f"{log}:33: damaged row" in err.read_text() and "Traceback" not in err.read_text()
    finally:
        subprocess.run(["tmux", "-L", sock, "kill-server"], capture_output=True)
