"""What the node pair of bench/nodes_bench.py is measured against: the contract's nominal bus load, the
raw python-can ping-pong anchor (bench.raw_anchor) on the virtual bus and over our hub, and the lockstep
run of the two node processes on vcan0 inside vcan-run (``python -m bench.nodes_bench --vcan-child``)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from bench.raw_anchor import anchor_process, anchor_virtual_cpu
from telethermo.nodes.launch import HubProcess
from telethermo.transport.bus import bus_load

ROOT = Path(__file__).resolve().parent.parent
VCAN_RUN = ROOT.parent / "shared" / "tools" / "vcan-run"


def nominal_bus_load(period_s: float) -> float:
    """The contract's load at 1 Mbit/s: SYNC (1 byte), two TPDO1 (8), the master's contact TPDO5 (1) and the
    slave's (8: the flag and its identified material) per cycle, each node's three status TPDOs (8 bytes)
    every 10th SYNC and the slave's TPDO6 (4 bytes, counted as 8) every 10th SYNC, two heartbeats (1 byte)
    every 100 ms."""
    f = 1.0 / period_s
    return bus_load({1: 2 * f + 2 * 10.0, 8: 3 * f + 2 * 3 * f / 10 + f / 10})


def vcan_lockstep(cycles: int, timeout_s: float = 1200) -> tuple[float | None, str]:
    """Lockstep cycles/s of the two node processes on vcan0 inside vcan-run; (value, note)."""
    if not VCAN_RUN.is_file():
        return None, f"{VCAN_RUN} not found: the kernel here has no vcan"
    cmd = [
        str(VCAN_RUN),
        "--timeout",
        str(int(timeout_s)),
        "--",
        "env",
        "PYTHONDONTWRITEBYTECODE=1",
        sys.executable,
        "-m",
        "bench.nodes_bench",
        "--vcan-child",
        str(cycles),
    ]
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s + 120, cwd=ROOT)
    except (OSError, subprocess.TimeoutExpired) as exc:
        return None, f"vcan-run failed: {exc}"
    for line in out.stdout.splitlines():
        if line.startswith("vcan-result "):
            res = json.loads(line[len("vcan-result ") :])
            return res["cycles_per_s"], (
                f"{cycles} cycles, two processes on vcan0 inside vcan-run (qemu software "
                "emulation: Python 10-20x slower than on the host; not comparable)"
            )
    tail = (out.stdout + out.stderr).strip().splitlines()[-5:]
    return None, f"vcan-run exit {out.returncode}: {' | '.join(tail)}"


# ---------------------------------------------------------------------------------------- the anchor
ANCHOR_FRAMES = (
    "per cycle, raw python-can: SYNC 0x080 (1 byte) + 0x181 (8) + 0x681 (1) out, 0x182 (8) + 0x682 (8) "
    "back, the next SYNC after 0x682 (the frames of one lockstep node cycle, without the status "
    "TPDOs every 10th SYNC and the heartbeats)"
)


def anchor_virtual(cycles: int, channel: str) -> tuple[float, float]:
    """Raw ping-pong on the virtual bus, the responder in a thread (bench.raw_anchor): (cycles/s, CPU s
    per cycle)."""
    return anchor_virtual_cpu(cycles, channel)


def anchor_hub(cycles: int) -> float:
    """Raw ping-pong cycles/s over our hub (the same program the node pair uses), the responder in
    another process (bench.raw_anchor)."""
    hub = HubProcess()
    hub.start()
    try:
        return anchor_process(cycles, hub.bus)
    finally:
        hub.stop()
