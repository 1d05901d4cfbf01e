"""``telethermo record`` keeps what it records: one CSV per log file name, no silent overwrite (``--force``
replaces), files readable by the group (the mode a new file gets), and Ctrl-C, the normal way to end a
recording, exits 0 with complete files. Real frames on a python-can virtual bus, and a real record process
on a real hub for Ctrl-C."""

from __future__ import annotations

import json
import os
import signal
import stat
import subprocess
import sys
import threading
import time

import can
import pytest

from telethermo.cli.main import EXIT_OK, EXIT_USAGE

pytestmark = pytest.mark.slow  # starts processes


def record_with_sync(cli, channel: str, out, *extra: str, frames: int = 20):
    """``telethermo record`` on a virtual bus while a thread sends SYNC frames; stops after ``frames``."""
    sender = can.Bus(interface="virtual", channel=channel)
    stop = threading.Event()

    def send():
        k = 0
        while not stop.is_set():
            sender.send(can.Message(arbitration_id=0x080, data=[k % 240 + 1], is_extended_id=False))
            k += 1
            time.sleep(0.002)  # paces the SYNC stream on purpose (a bus at ~500 frames/s)

    th = threading.Thread(target=send)
    th.start()
    try:
        return cli(
            "record",
            "--bus",
            f"virtual:{channel}",
            str(out),
            "--count",
            str(frames),
            "--duration",
            "60",
            *extra,
        )
    finally:
        stop.set()
        th.join()
        sender.shutdown()


def test_one_csv_per_log_name_and_no_silent_overwrite(cli, tmp_path):
    channel = f"tt-rec-{time.monotonic_ns()}"
    for ext, n in ((".log", 10), (".blf", 20), (".asc", 30)):
        code, out, err = record_with_sync(cli, channel, tmp_path / f"s{ext}", frames=n)
        assert code == EXIT_OK, err
    for ext, n in ((".log", 10), (".blf", 20), (".asc", 30)):
        rows = (tmp_path / f"s{ext}.csv").read_text().splitlines()
        assert len(rows) == n + 1, ext  # each log kept its own decoded CSV
        assert len(list(can.LogReader(str(tmp_path / f"s{ext}")))) == n
    assert not (tmp_path / "s.csv").exists()

    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    code, out, err = record_with_sync(cli, channel, tmp_path / "s.blf", frames=5)
    assert code == EXIT_USAGE
    assert err.strip() == (
        f"telethermo record: error: {tmp_path / 's.blf'} and {tmp_path / 's.blf.csv'} already exist; "
        "give another name, or --force to replace, or --append"
    )
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before  # nothing touched
    # only the CSV there (the log was removed): still refused, naming it
    (tmp_path / "s.log").unlink()
    code, out, err = record_with_sync(cli, channel, tmp_path / "s.log", frames=5)
    assert code == EXIT_USAGE and f"{tmp_path / 's.log.csv'} already exists;" in err
    code, out, err = record_with_sync(cli, channel, tmp_path / "s.blf", "--force", frames=5)
    assert code == EXIT_OK, err
    assert len((tmp_path / "s.blf.csv").read_text().splitlines()) == 6


@pytest.mark.parametrize("umask", [0o022, 0o027])
def test_files_get_the_mode_a_new_file_gets(cli, tmp_path, umask):
    old = os.umask(umask)
    try:
        code, out, err = record_with_sync(
            cli, f"tt-rec-mode-{time.monotonic_ns()}", tmp_path / "m.log", frames=3
        )
    finally:
        os.umask(old)
    assert code == EXIT_OK, err
    for name in ("m.log", "m.log.csv"):
        assert stat.S_IMODE((tmp_path / name).stat().st_mode) == 0o666 & ~umask, name


def test_ctrl_c_is_the_normal_stop(tmp_path):
    from telethermo.nodes.launch import HubProcess, stop_process

    hub = HubProcess()
    hub.start()
    sender = None
    proc = None
    try:
        sender = can.Bus(interface="socketcand", host="127.0.0.1", port=hub.port, channel="telethermo")
        log = tmp_path / "c.blf"
        proc = subprocess.Popen(
            [sys.executable, "-m", "telethermo", "record", "--bus", hub.bus, str(log)],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        line = proc.stderr.readline()  # "recording ... (Ctrl-C stops)" once the bus is open
        assert line.startswith("recording socketcand://"), line
        k = 0
        t_end = time.monotonic() + 2.0  # frames flow while the recording runs, then Ctrl-C
        while time.monotonic() < t_end:
            sender.send(can.Message(arbitration_id=0x080, data=[k % 240 + 1], is_extended_id=False))
            k += 1
            time.sleep(0.01)  # paces the SYNC stream on purpose (100 frames/s for 2 s)
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=30)
        assert proc.returncode == 0, err
        assert "(stopped by Ctrl-C)" in out and "Traceback" not in err
        n = int(out.split()[1])  # "recorded N frames to ..."
        assert 1 <= n <= k
        back = list(can.LogReader(str(log)))  # complete: every frame counted is in the log and the CSV
        assert len(back) == n and len((tmp_path / "c.blf.csv").read_text().splitlines()) == n + 1
        assert [m.data[0] for m in back] == [i % 240 + 1 for i in range(n)]  # the first n sent, in order
    finally:
        if proc is not None and proc.poll() is None:
            stop_process(proc)
        if sender is not None:
            sender.shutdown()
        hub.stop()


def test_record_trc_and_its_csv_replay_through_the_monitor(cli, tmp_path):
    channel = f"tt-rec-trc-{time.monotonic_ns()}"
    code, out, err = record_with_sync(cli, channel, tmp_path / "s.trc", frames=25)
    assert code == EXIT_OK, err
    assert (tmp_path / "s.trc").read_text().startswith(";$FILEVERSION=2.1")  # PEAK trace, python-can's writer
    for log in ("s.trc", "s.trc.csv"):
        code, out, err = cli("monitor", "--replay", str(tmp_path / log), "--json", "--no-frames")
        assert code == EXIT_OK, err
        status = json.loads(out.strip().splitlines()[-1])
        assert status["type"] == "status" and status["frames"] == 25 and status["syncs"] == 25, log
        assert status["sync_counter_errors"] == 0 and status["malformed"] == 0, log
    rows = (tmp_path / "s.trc.csv").read_text().splitlines()
    rows[7] = rows[7].replace(",1,", ",3,", 1)  # dlc 3 with one data byte
    (tmp_path / "bad.csv").write_text("\n".join(rows) + "\n")
    code, out, err = cli("monitor", "--replay", str(tmp_path / "bad.csv"), "--json", "--no-frames")
    assert code != EXIT_OK and f"{tmp_path / 'bad.csv'}:8: damaged row (dlc 3 but 1 data bytes)" in err


def test_a_candump_log_keeps_the_hub_channel_name(tmp_path):
    """Issue 25: `record x.log` wrote hub frames as channel vcan0; the hub's channel is `telethermo`."""
    from telethermo.nodes.launch import HubProcess

    hub = HubProcess()
    hub.start()
    sender = None
    try:
        sender = can.Bus(interface="socketcand", host="127.0.0.1", port=hub.port, channel="telethermo")
        log = tmp_path / "h.log"
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "telethermo",
                "record",
                "--bus",
                hub.bus,
                str(log),
                "--count",
                "5",
                "--duration",
                "60",
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        assert proc.stderr.readline().startswith("recording socketcand://")
        while proc.poll() is None:
            sender.send(can.Message(arbitration_id=0x080, data=[1], is_extended_id=False))
            time.sleep(0.02)  # paces the frames on purpose (50/s until the recorder stops by itself)
        out, err = proc.communicate(timeout=30)
        assert proc.returncode == 0, err
        lines = log.read_text().splitlines()
        assert len(lines) == 5 and all(line.split()[1:3] == ["telethermo", "080#01"] for line in lines), lines
        assert all(m.channel == "telethermo" for m in can.LogReader(str(log)))
    finally:
        if sender is not None:
            sender.shutdown()
        hub.stop()


def test_a_missing_folder_is_refused_not_created(cli, tmp_path):
    """Issue 25: `record` created missing parent folders at any depth; a typo now is one line, exit 2."""
    target = tmp_path / "runs" / "2024" / "s.log"
    code, out, err = cli("record", "--bus", "virtual:tt-rec-nofolder", str(target), "--duration", "0.1")
    assert code == EXIT_USAGE
    assert err == (
        f"telethermo record: error: {target}: the folder {target.parent} does not exist; "
        "expected an existing folder (create it first)\n"
    )
    assert not (tmp_path / "runs").exists()
    code, out, err = cli(
        "record",
        "--bus",
        "virtual:tt-rec-nofolder",
        str(tmp_path / "s.log"),
        "--csv",
        str(tmp_path / "csv" / "s.csv"),
        "--duration",
        "0.1",
    )
    assert code == EXIT_USAGE and f"the folder {tmp_path / 'csv'} does not exist" in err
    assert not (tmp_path / "csv").exists() and not (tmp_path / "s.log").exists()


def record_frames(cli, out, frames, *extra: str):
    """``telethermo record`` on a virtual bus while a thread sends ``frames`` (COB-ID, data) in turn until the
    recording ends (by --duration)."""
    channel = f"tt-rec-f-{time.monotonic_ns()}"
    sender = can.Bus(interface="virtual", channel=channel)
    stop = threading.Event()

    def send():
        while not stop.is_set():
            for cob, data in frames:
                sender.send(can.Message(arbitration_id=cob, data=data, is_extended_id=False))
            time.sleep(0.005)  # paces the frame mix on purpose (one round every 5 ms)

    th = threading.Thread(target=send)
    th.start()
    try:
        return cli("record", "--bus", f"virtual:{channel}", str(out), "--duration", "60", *extra)
    finally:
        stop.set()
        th.join()
        sender.shutdown()


TPDO4 = bytes([0x10, 0x27, 0, 0, 1, 1, 1, 1])  # cycle_counter 10000, safety 1, mode 1, contact, peer alive
MIX = [
    (0x080, b"\x01"),
    (0x181, bytes(8)),
    (0x481, TPDO4),
    (0x482, TPDO4),
    (0x701, b"\x05"),
    (0x702, b"\x05"),
]


@pytest.mark.parametrize(
    "spec,cobs",
    [
        ("sync", {0x080}),
        ("181:7FF", {0x181}),
        ("480:780", {0x481, 0x482}),
        ("700~780", {0x080, 0x181, 0x481, 0x482}),
        ("slave", {0x482, 0x702}),
        ("cycle_counter", {0x481, 0x482}),
        ("master.TPDO4,heartbeat", {0x481, 0x701, 0x702}),
    ],
)
def test_filter_keeps_only_the_matching_frames(cli, tmp_path, spec, cobs):
    code, out, err = record_frames(cli, tmp_path / "f.log", MIX, "--filter", spec, "--count", "40")
    assert code == EXIT_OK, err
    back = list(can.LogReader(str(tmp_path / "f.log")))
    assert len(back) == 40 and {m.arbitration_id for m in back} == cobs
    assert len((tmp_path / "f.log.csv").read_text().splitlines()) == 41


def test_a_bad_filter_is_one_line(cli, tmp_path):
    code, out, err = cli(
        "record", "--bus", "virtual:tt-rec-badf", str(tmp_path / "f.log"), "--filter", "18x:780"
    )
    assert code == EXIT_USAGE
    assert err == (
        "telethermo record: error: --filter '18x:780': '18x' is not hexadecimal; "
        "expected ID:MASK or ID~MASK as python-can's --filter, e.g. 180:780\n"
    )
    assert not (tmp_path / "f.log").exists()


@pytest.mark.parametrize("ext", [".log", ".blf"])
def test_append_adds_to_the_log_and_its_csv(cli, tmp_path, ext):
    log = tmp_path / f"a{ext}"
    for n in (10, 15):
        code, out, err = record_frames(
            cli, log, [(0x080, b"\x01")], "--count", str(n), *(["--append"] if n == 15 else [])
        )
        assert code == EXIT_OK, err
    assert len(list(can.LogReader(str(log)))) == 25
    rows = (tmp_path / f"a{ext}.csv").read_text().splitlines()
    assert len(rows) == 26 and rows.count(rows[0]) == 1  # one header, the rows of both recordings
    code, out, err = cli("record", "--bus", "virtual:tt-rec-asc", str(tmp_path / "a.asc"), "--append")
    assert code == EXIT_USAGE
    assert err == (
        f"telethermo record: error: {tmp_path / 'a.asc'}: cannot append to a "
        ".asc log (python-can's writer cannot); expected one of .log, .blf\n"
    )
