"""The socketcand-protocol hub against python-can's own socketcand client (a client no one here wrote)."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import can
import pytest

from telethermo.nodes.launch import wait_for
from telethermo.transport.hub import HubConfig, HubThread, format_frame, parse_send

pytestmark = pytest.mark.slow  # starts processes


def _client(port: int, channel: str = "vcan0") -> can.BusABC:
    return can.Bus(interface="socketcand", host="127.0.0.1", port=port, channel=channel, tcp_tune=True)


def _recv_all(bus: can.BusABC, n: int, timeout_s: float = 5.0) -> list[can.Message]:
    got = []
    deadline = time.monotonic() + timeout_s
    while len(got) < n and time.monotonic() < deadline:
        msg = bus.recv(0.2)
        if msg is not None:
            got.append(msg)
    return got


def _settle(hub: HubThread, n_clients: int) -> None:
    """Wait until the hub has n raw clients past their join grace (frames held before are delivered later)."""
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline:
        clients = list(hub.hub._clients.values())
        if len(clients) == n_clients and all(c.raw and time.monotonic() > c.release_at for c in clients):
            return
        time.sleep(0.02)
    raise AssertionError("clients did not join")


def test_forwards_in_order_without_echo_and_losslessly():
    with HubThread() as hub:
        a, b, c = _client(hub.port), _client(hub.port), _client(hub.port)
        try:
            _settle(hub, 3)
            sent = [
                can.Message(
                    arbitration_id=0x180 + (i % 3),
                    data=i.to_bytes(4, "little") + bytes([i % 256] * 4),
                    is_extended_id=False,
                )
                for i in range(2000)
            ]
            sent.append(can.Message(arbitration_id=0x80, data=b"", is_extended_id=False))  # DLC 0 (SYNC)
            sent.append(can.Message(arbitration_id=0x1ABCDE12, data=b"\x01\x02", is_extended_id=True))
            for m in sent:
                a.send(m)
            for rx in (b, c):
                got = _recv_all(rx, len(sent))
                assert len(got) == len(sent)
                for m, g in zip(sent, got):
                    assert (g.arbitration_id, bytes(g.data), g.is_extended_id, g.dlc) == (
                        m.arbitration_id,
                        bytes(m.data),
                        m.is_extended_id,
                        len(m.data),
                    )
            assert a.recv(0.3) is None  # no echo to the sender
            assert hub.hub.stats.frames_in == len(sent)
            assert hub.hub.stats.frames_out == 2 * len(sent)
        finally:
            for bus in (a, b, c):
                bus.shutdown()


def test_channels_are_separate_buses():
    with HubThread() as hub:
        a, b, other = _client(hub.port, "vcan0"), _client(hub.port, "vcan0"), _client(hub.port, "vcan1")
        try:
            _settle(hub, 3)
            a.send(can.Message(arbitration_id=0x123, data=b"\x01", is_extended_id=False))
            assert [m.arbitration_id for m in _recv_all(b, 1)] == [0x123]
            assert other.recv(0.3) is None
        finally:
            for bus in (a, b, other):
                bus.shutdown()


def test_frames_during_join_are_held_then_delivered():
    with HubThread(HubConfig(idle_timeout_s=0, join_grace_s=0.3)) as hub:
        a = _client(hub.port)
        b = _client(hub.port)  # b's grace period is running: a's frames must be held, not glued to < ok >
        try:
            for i in range(10):
                a.send(can.Message(arbitration_id=0x200, data=bytes([i]), is_extended_id=False))
            got = _recv_all(b, 10)
            assert [m.data[0] for m in got] == list(range(10))
        finally:
            a.shutdown()
            b.shutdown()


def test_malformed_commands_are_counted_and_ignored():
    with HubThread() as hub:
        rx = _client(hub.port)
        raw = socket.create_connection(("127.0.0.1", hub.port))
        try:
            assert raw.recv(64) == b"< hi >"
            raw.sendall(b"< open vcan0 >")
            assert raw.recv(64) == b"< ok >"
            raw.sendall(b"< rawmode >")
            assert raw.recv(64) == b"< ok >"
            _settle(hub, 2)
            bad = [
                b"< send 123 3 1 2 >",  # DLC says 3, two bytes
                b"< send 800 1 1 >",  # 11-bit ID out of range
                b"< send 12 1 1 >",  # ID neither 3 nor 8 digits
                b"< send 123 9 1 2 3 4 5 6 7 8 9 >",  # DLC 9
                b"< send 123 1 zz >",  # not hex
                b"< bogus >",
                b"garbage",
            ]
            raw.sendall(b"".join(bad) + b"< send 321 2 a b >")
            got = _recv_all(rx, 1)
            assert [(m.arbitration_id, bytes(m.data)) for m in got] == [(0x321, b"\x0a\x0b")]
            assert rx.recv(0.3) is None
            assert hub.hub.stats.malformed == len(bad)
        finally:
            raw.close()
            rx.shutdown()


def test_protocol_helpers():
    assert parse_send("send 1FFFFFFF 2 ff 0") == ("1FFFFFFF", b"\xff\x00")
    assert parse_send("send 080 0") == ("080", b"")
    assert parse_send("send 080 1") is None
    assert format_frame("181", b"\x01\xab", 12.5) == b"< frame 181 12.500000 01AB >"


def test_refuses_non_loopback_address():
    with pytest.raises(ValueError, match="loopback"):
        HubConfig(host="0.0.0.0")
    out = subprocess.run(
        [sys.executable, "-m", "telethermo.transport.hub", "--host", "0.0.0.0"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 2 and "loopback" in out.stderr


def _start_hub_process(*extra: str) -> tuple[subprocess.Popen, int]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "telethermo.transport.hub", "--port", "0", *extra],
        stdout=subprocess.PIPE,
        text=True,
    )
    line = proc.stdout.readline()
    assert line.startswith("telethermo-hub listening on 127.0.0.1:"), line
    return proc, int(line.rsplit(":", 1)[1])


def test_hub_process_serves_two_clients_and_stops_when_idle():
    proc, port = _start_hub_process("--idle-timeout", "0.5")
    try:
        a, b = _client(port), _client(port)  # a frame sent in b's join grace is held, then delivered
        a.send(can.Message(arbitration_id=0x701, data=b"\x05", is_extended_id=False))
        assert [(m.arbitration_id, bytes(m.data)) for m in _recv_all(b, 1)] == [(0x701, b"\x05")]
        a.shutdown()
        b.shutdown()
        assert proc.wait(timeout=30) == 0
        assert "idle" in proc.stdout.read()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_hub_process_stops_when_its_parent_ends():
    # a parent that starts the hub, prints the hub's pid and exits
    code = (
        "import subprocess, sys; p = subprocess.Popen([sys.executable, '-m', 'telethermo.transport.hub', "
        "'--idle-timeout', '0'], stdout=subprocess.DEVNULL); print(p.pid, flush=True)"
    )
    parent = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    pid = int(parent.stdout.strip())

    def gone() -> bool:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return True
        return False

    if not wait_for(gone, 30, poll_s=0.1):
        os.kill(pid, 9)
        raise AssertionError("hub outlived its parent")


def test_hub_watching_another_process_outlives_its_own_parent(tmp_path):
    # the lab's case: `setsid nohup telethermo-hub --parent-pid P &` (the hub is re-parented at once) must run
    # as long as P does, and stop when P ends
    watched = subprocess.Popen(["sleep", "120"])
    port_file = tmp_path / "port"
    code = (
        "import subprocess, sys; p = subprocess.Popen([sys.executable, '-m', 'telethermo.transport.hub', "
        f"'--idle-timeout', '0', '--no-publish', '--port', '0', '--port-file', {str(port_file)!r}, "
        f"'--parent-pid', '{watched.pid}'], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, "
        "start_new_session=True); print(p.pid, flush=True)"
    )
    try:
        parent = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
        pid = int(parent.stdout.strip())

        def gone() -> bool:  # ended: no such process, or a zombie that init has not reaped yet
            try:
                return Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()[0] == "Z"
            except OSError:
                return True

        assert wait_for(lambda: port_file.exists() and port_file.read_text().strip() != "", 60, poll_s=0.05)
        # listening, its parent gone: the parent check runs every 0.25 s, so four checks have passed by now
        time.sleep(1.0)
        assert not gone(), "the hub stopped although the process it watches still runs"
        watched.kill()
        watched.wait()
        if not wait_for(gone, 30, poll_s=0.1):
            os.kill(pid, 9)
            raise AssertionError("hub outlived the process it watches")
    finally:
        if watched.poll() is None:
            watched.kill()
            watched.wait()
