"""The SocketCAN group: needs a real vcan interface (env TELETHERMO_VCAN, default vcan0).

Run natively where the kernel has vcan, else inside ../shared/tools/vcan-run (scripts/run-tests
does this). Without the interface the tests are skipped and say why.
"""
from __future__ import annotations

import os
import shutil
import subprocess

import pytest


@pytest.fixture(scope="session")
def vcan_channel() -> str:
    name = os.environ.get("TELETHERMO_VCAN", "vcan0")
    if not os.path.exists(f"/sys/class/net/{name}"):
        pytest.skip(f"SocketCAN interface {name!r} does not exist on this kernel (set TELETHERMO_VCAN, "
                    "or run inside ../shared/tools/vcan-run)")
    return name


class Candump:
    """``candump`` (Debian's can-utils: a client no one here wrote) logging every frame on a channel."""

    def __init__(self, channel: str) -> None:
        exe = shutil.which("candump")
        if exe is None:
            pytest.skip("candump not installed (apt-get install can-utils): cross-check skipped")
        # -L: log format "(sec.usec) vcan0 181#0011223344556677"
        self.proc = subprocess.Popen([exe, "-L", channel], stdout=subprocess.PIPE, text=True)

    def stop(self) -> list[tuple[int, bytes]]:
        """Stop it (SIGINT, by pid) and return the frames it saw as (COB-ID, data)."""
        self.proc.send_signal(2)
        out, _ = self.proc.communicate(timeout=30)
        frames = []
        for line in out.splitlines():
            parts = line.split()
            if len(parts) == 3 and "#" in parts[2]:
                ident, data = parts[2].split("#", 1)
                frames.append((int(ident, 16), bytes.fromhex(data)))
        return frames


@pytest.fixture
def candump(vcan_channel):
    dumps = []

    def start() -> Candump:
        d = Candump(vcan_channel)
        dumps.append(d)
        return d

    yield start
    for d in dumps:
        if d.proc.poll() is None:
            d.proc.kill()
            d.proc.wait()
