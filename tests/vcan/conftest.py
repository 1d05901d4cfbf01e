"""The SocketCAN group: needs a real vcan interface (env TELETHERMO_VCAN, default vcan0).

Run natively where the kernel has vcan, else inside ../shared/tools/vcan-run (scripts/run-tests
does this). Without the interface the tests are skipped and say why.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import time
from pathlib import Path

import can
import pytest

from telethermo.bus_config import path as bus_config_path


def slow_machine_network(tmp_path: Path, channel: str = "vcan0") -> Path:
    """The packaged network settings on ``channel`` with heartbeat times for a machine 10-20x slower than
    usual (the VM of ../shared/tools/vcan-run)."""
    text = f"""
[bus]
interface = "socketcan"
channel = "{channel}"
[sync]
producer = "master"
period_s = 0.010
lockstep = true
[heartbeat]
producer_ms = 200
consumer_ms = 3000
[nodes.master]
node_id = 1
eds = "{bus_config_path("master.eds")}"
[nodes.slave]
node_id = 2
eds = "{bus_config_path("slave.eds")}"
"""
    p = tmp_path / "network.toml"
    p.write_text(text)
    return p


@pytest.fixture
def slow_network(tmp_path, vcan_channel) -> Path:
    return slow_machine_network(tmp_path, vcan_channel)


@pytest.fixture(scope="session")
def vcan_channel() -> str:
    name = os.environ.get("TELETHERMO_VCAN", "vcan0")
    if not os.path.exists(f"/sys/class/net/{name}"):
        pytest.skip(
            f"SocketCAN interface {name!r} does not exist on this kernel (set TELETHERMO_VCAN, "
            "or run inside ../shared/tools/vcan-run)"
        )
    return name


#: candump's socket receive buffer, bytes (``-r``)
RCVBUF_BYTES = 8 * 1024 * 1024
#: the 29-bit ID of the test's marker frames to candump: no CANopen service (our devices count it as an
#: unknown frame, canopen's clients ignore it), left out of :meth:`Candump.stop`'s frames
MARKER_ID = 0x1FFFFFF0


class Candump:
    """``candump`` (Debian's can-utils: a client no one here wrote) logging every frame on a channel.

    It gives no sign that it listens, and it drops what is still in its socket when SIGINT comes: the test
    sends it a marker frame (``MARKER_ID``) and waits, bounded, until candump has logged it, once it is
    started (it listens from then on) and before it is stopped (vcan queues frames in the order they were
    sent, so every frame sent before the marker is logged). A fixed sleep instead (1 s, 0.5 s) lost the
    first or the last frames when a loaded machine or the VM of vcan-run was slower than that."""

    def __init__(self, channel: str, log_path: Path) -> None:
        exe = shutil.which("candump")
        if exe is None:
            pytest.skip("candump not installed (apt-get install can-utils): cross-check skipped")
        # -L: log format "(sec.usec) vcan0 181#0011223344556677"; into a file, not a pipe: nobody reads a
        # pipe while the test runs, and a full pipe (64 kB) would block candump and make it lose frames. A
        # named file, not an unlinked temporary one: in ../shared/tools/vcan-run the file system is the host's
        # over 9p, where an open file that has no name can be lost under memory pressure (ENOENT on read).
        # stdbuf -oL: a line in the file per frame as it comes (the markers are read while it runs). -r: an
        # 8 MB socket receive buffer (SO_RCVBUFFORCE as root, else capped by rmem_max; a line about it in
        # the log is not a frame): with the default one, candump starved by two CPU hogs lost 9 % of a
        # 2700-frame identification
        self.channel, self.log_path, self.markers = channel, log_path, 0
        self.log = open(log_path, "w+", encoding="utf-8")
        cmd = ["stdbuf", "-oL", exe, "-L", "-r", str(RCVBUF_BYTES), channel]
        self.proc = subprocess.Popen(cmd, stdout=self.log, text=True)
        self.mark()

    def mark(self, timeout_s: float = 120.0) -> None:
        """Send a marker frame (again every second) until candump has logged it."""
        self.markers += 1
        data = self.markers.to_bytes(4, "little")
        line = f"{MARKER_ID:08X}#{data.hex().upper()}"
        bus = can.Bus(interface="socketcan", channel=self.channel)
        try:
            deadline = time.monotonic() + timeout_s
            while True:
                bus.send(can.Message(arbitration_id=MARKER_ID, data=data, is_extended_id=True))
                resend = time.monotonic() + 1.0
                while time.monotonic() < resend:
                    if line in self.log_path.read_text(encoding="utf-8"):
                        return
                    time.sleep(0.02)
                assert self.proc.poll() is None, f"candump exited ({self.proc.returncode})"
                assert time.monotonic() < deadline, f"candump did not log its marker within {timeout_s} s"
        finally:
            bus.shutdown()

    def stop(self) -> list[tuple[int, bytes]]:
        """Stop it (SIGINT, by pid) once every frame sent so far is logged and return the frames it saw as
        (COB-ID, data), the markers left out."""
        self.mark()
        self.proc.send_signal(2)
        self.proc.wait(timeout=30)
        self.log.seek(0)
        out = self.log.read()
        self.log.close()
        frames = []
        for line in out.splitlines():
            parts = line.split()
            if len(parts) == 3 and "#" in parts[2]:
                ident, data = parts[2].split("#", 1)
                if int(ident, 16) != MARKER_ID:
                    frames.append((int(ident, 16), bytes.fromhex(data)))
        return frames


@pytest.fixture
def candump(vcan_channel, tmp_path):
    dumps = []

    def start() -> Candump:
        d = Candump(vcan_channel, tmp_path / f"candump-{len(dumps)}.log")
        dumps.append(d)
        return d

    yield start
    for d in dumps:
        if d.proc.poll() is None:
            d.proc.kill()
            d.proc.wait()
