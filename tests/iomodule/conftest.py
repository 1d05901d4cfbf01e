"""A hub, a ``telethermo-iomodule`` process on it and the test's own client of it
(tests/iomodule/helpers.py)."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

import pytest

from telethermo.transport.hub import HubThread
from tests.iomodule.helpers import MODULE_ID, Bus, up


@pytest.fixture
def rig():
    """A hub, a running ``telethermo-iomodule`` on it and the test's RemoteNode of it, answering SDO."""
    with HubThread() as hub:
        exe = Path(sys.executable).with_name("telethermo-iomodule")
        proc = subprocess.Popen(
            [
                str(exe),
                "--node-id",
                str(MODULE_ID),
                "--scene",
                "pads_in_air",
                "--bus",
                f"socketcand://127.0.0.1:{hub.port}/vcan0",
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        bus = Bus(hub.port)
        try:
            bus.wait(lambda: up(bus) or proc.poll() is not None, timeout_s=60, every_s=0.1)
            assert proc.poll() is None, proc.communicate()[1]
            yield hub, bus, proc
        finally:
            bus.close()
            proc.send_signal(signal.SIGTERM)
            try:
                assert proc.wait(timeout=20) == 0, proc.communicate()[1]
            finally:
                if proc.poll() is None:
                    proc.kill()
