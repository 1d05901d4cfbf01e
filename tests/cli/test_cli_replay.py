"""``telethermo replay LOG --bus B`` (issue 25: replay a log onto the bus, can.player's job, with the filters
the recorder knows). A log written by python-can's own writer is sent onto a python-can virtual bus; a plain
python-can listener on that bus gets the frames, in order, identifiers and data as recorded, only those the
filter keeps; a damaged log stops with one line saying how many frames were sent."""

from __future__ import annotations

import struct
import time

import can

from telethermo.cli.main import EXIT_OK, EXIT_USAGE


def frames(n: int):
    for k in range(n):
        t = 50.0 + 0.001 * k
        yield can.Message(timestamp=t, arbitration_id=0x080, data=bytes([k % 240 + 1]), is_extended_id=False)
        yield can.Message(
            timestamp=t + 0.0002,
            arbitration_id=0x181,
            data=struct.pack("<ff", 30.0 + k, 0.5),
            is_extended_id=False,
        )
        yield can.Message(timestamp=t + 0.0004, arbitration_id=0x702, data=b"\x05", is_extended_id=False)


def write(path, n: int):
    with can.Logger(str(path)) as log:
        for m in frames(n):
            log.on_message_received(m)


def received(listener: can.BusABC) -> list[can.Message]:
    out = []
    while (m := listener.recv(0.2)) is not None:
        out.append(m)
    return out


def test_replay_sends_the_recorded_frames_in_order(cli, tmp_path):
    log = tmp_path / "s.blf"
    write(log, 40)
    channel = f"tt-replay-{time.monotonic_ns()}"
    listener = can.Bus(interface="virtual", channel=channel)
    try:
        code, out, err = cli("replay", str(log), "--bus", f"virtual:{channel}", "--speed", "0")
        assert code == EXIT_OK, err
        got = received(listener)
        want = list(frames(40))

        def frames_of(msgs):
            return [(m.arbitration_id, bytes(m.data)) for m in msgs]

        assert frames_of(got) == frames_of(want)
        assert out == f"replayed 120 frames of {log} onto virtual:{channel}\n"
        code, out, err = cli(
            "replay", str(log), "--bus", f"virtual:{channel}", "--speed", "0", "--filter", "master,sync"
        )  # the master's TPDO1 and every SYNC; not the slave's heartbeat
        assert code == EXIT_OK, err
        assert [m.arbitration_id for m in received(listener)] == [0x080, 0x181] * 40
    finally:
        listener.shutdown()


def test_replay_at_the_recorded_pace_keeps_the_spacing(cli, tmp_path):
    log = tmp_path / "p.log"
    with can.Logger(str(log)) as lg:
        for k in range(6):
            lg.on_message_received(
                can.Message(
                    timestamp=10.0 + 0.1 * k, arbitration_id=0x080, data=[k + 1], is_extended_id=False
                )
            )
    channel = f"tt-replay-pace-{time.monotonic_ns()}"
    listener = can.Bus(interface="virtual", channel=channel)
    try:
        code, out, err = cli("replay", str(log), "--bus", f"virtual:{channel}")
        assert code == EXIT_OK, err
        got = received(listener)
        assert [m.data[0] for m in got] == [1, 2, 3, 4, 5, 6]
        assert got[-1].timestamp - got[0].timestamp >= 0.5 - 1e-3  # not earlier than recorded
    finally:
        listener.shutdown()


def test_a_damaged_log_says_how_many_frames_were_sent(cli, tmp_path):
    good = tmp_path / "g.log"
    write(good, 10)
    lines = good.read_text().splitlines()
    lines[6] = "(50.1) can0 zz"
    bad = tmp_path / "bad.log"
    bad.write_text("\n".join(lines) + "\n")
    channel = f"tt-replay-bad-{time.monotonic_ns()}"
    listener = can.Bus(interface="virtual", channel=channel)
    try:
        code, out, err = cli("replay", str(bad), "--bus", f"virtual:{channel}", "--speed", "0")
        started, error = err.splitlines()  # the "replaying ..." line, then the error: one line
        assert code == EXIT_USAGE and started.startswith(f"replaying {bad} onto virtual:")
        assert error.startswith(f"telethermo replay: error: {bad}:7: damaged line (ValueError: ")
        assert error.endswith("; 6 frames were sent") and len(received(listener)) == 6
        code, out, err = cli(
            "replay", str(tmp_path / "g.log"), "--bus", f"virtual:{channel}", "--filter", "bogus"
        )
        assert code == EXIT_USAGE
        assert err.startswith("telethermo replay: error: --filter 'bogus': not ID:MASK")
    finally:
        listener.shutdown()
