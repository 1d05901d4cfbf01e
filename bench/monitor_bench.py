"""The monitor's decode rate against python-can's raw receive rate, measured in one run (issue 13: the
monitor must keep up with a full 1 Mbit/s bus, >= 8,000 frames/s):

    python -m bench.monitor_bench [--quick]

The traffic is a synthesised realistic mix of the telethermo pair at a 1 ms SYNC period, with the
shipped EDS files: per cycle SYNC (with counter), both nodes' TPDO1 (8 bytes, two REAL32) and TPDO5
(1 byte); every 100 cycles both heartbeats and an expedited SDO read of node 1 (request + response);
every 1000 cycles an EMCY and its reset. Timestamps are bus time (the monitor reads no clock).

- ``anchor_frames_per_s``: python-can alone: the same frames, already in a ``virtual`` bus's receive
  queue, taken out with ``bus.recv()`` (what any monitor must do for each frame, and nothing else);
- ``decode_frames_per_s``: :class:`telethermo.monitor.state.Monitor.feed` alone on the same frames (the
  pure state machine: classification, SDO/PDO/heartbeat/SYNC decoding, statistics, frame table);
- ``live_frames_per_s``: both, as the live monitor runs them: ``recv()`` then ``feed()`` per frame.

Medians over the repeats, each measure interleaved with the others. ``ratio_vs_anchor`` =
decode / anchor; ``keeps_up_8k``: both the decode and the live rate >= 8,000 frames/s. Writes
bench/results/monitor.json. --quick: 20,000 frames, 3 repeats (a few seconds).
"""
from __future__ import annotations

import argparse
import statistics
import struct
import time
from typing import Any

import can
from canopen.objectdictionary import import_od

from bench.common import print_table, write_results
from telethermo.device.netconfig import load_network
from telethermo.monitor.records import MonitorConfig, NodeInfo
from telethermo.monitor.state import Monitor
from telethermo.remote.targets import node_targets

TARGET_FRAMES_PER_S = 8000
PERIOD_S = 0.001


def traffic(n_frames: int) -> list[can.Message]:
    """``n_frames`` frames of the mix described in the module docstring."""
    out: list[can.Message] = []
    t, k = 1_700_000_000.0, 0

    def add(dt: float, cob: int, data: bytes) -> None:
        out.append(can.Message(timestamp=t + dt, arbitration_id=cob, data=data, is_extended_id=False))

    add(0.0, 0x701, b"\x05")
    add(0.0, 0x702, b"\x05")
    while len(out) < n_frames:
        k += 1
        t += PERIOD_S
        add(0.0, 0x080, bytes([(k - 1) % 240 + 1]))
        add(0.0001, 0x181, struct.pack("<ff", 30.0 + 1e-4 * (k % 1000), -0.5))
        add(0.0002, 0x182, struct.pack("<ff", 24.0, 0.5))
        add(0.0003, 0x681, b"\x01")
        add(0.0004, 0x682, b"\x01\x00\x00\x00\x00\x00\x00\x00")   # slave TPDO5: contact + identification
        if k % 100 == 0:
            add(0.0005, 0x701, b"\x05")
            add(0.0005, 0x702, b"\x05")
            add(0.0006, 0x601, struct.pack("<BHB4x", 0x40, 0x1017, 0))
            add(0.0007, 0x581, struct.pack("<BHBL", 0x4B, 0x1017, 0, 100))
        if k % 1000 == 500:
            add(0.0008, 0x082, struct.pack("<HB5s", 0x4210, 0x09, bytes(5)))
            add(0.0009, 0x082, bytes(8))
    return out[:n_frames]


def monitor_config() -> MonitorConfig:
    """Both shipped nodes by their EDS, 1 Mbit/s, the 1 ms period of the traffic."""
    nodes = {t.node_id: NodeInfo(t.role, import_od(str(t.eds), t.node_id)) for t in node_targets(load_network())}
    return MonitorConfig(nodes=nodes, bitrate_bps=1_000_000, sync_period_s=PERIOD_S)


def _fill(frames: list[can.Message], channel: str) -> tuple[can.BusABC, can.BusABC]:
    tx = can.Bus(interface="virtual", channel=channel, preserve_timestamps=True)   # bus time of the mix
    rx = can.Bus(interface="virtual", channel=channel)
    for m in frames:
        tx.send(m)
    return tx, rx


def rate_recv(frames: list[can.Message], channel: str, *, decode: bool) -> float:
    """Frames/s of ``recv()`` (and ``feed()`` if ``decode``) on a filled virtual bus."""
    tx, rx = _fill(frames, channel)
    mon = Monitor(monitor_config()) if decode else None
    try:
        t0 = time.perf_counter()
        for _ in range(len(frames)):
            m = rx.recv(1.0)
            if mon is not None:
                mon.feed(m)
        return len(frames) / (time.perf_counter() - t0)
    finally:
        tx.shutdown()
        rx.shutdown()


def rate_decode(frames: list[can.Message]) -> float:
    """Frames/s of ``Monitor.feed`` alone."""
    mon = Monitor(monitor_config())
    t0 = time.perf_counter()
    for m in frames:
        mon.feed(m)
    return len(frames) / (time.perf_counter() - t0)


def measure(quick: bool, n_frames: int | None = None) -> dict[str, Any]:
    n, repeats = (20_000, 3) if quick else (100_000, 5)
    n = n_frames or n
    frames = traffic(n)
    runs: dict[str, list[float]] = {"anchor": [], "decode": [], "live": []}
    rate_decode(frames[:2000])     # warm-up: imports, EDS parsing caches
    for r in range(repeats):
        runs["anchor"].append(rate_recv(frames, f"tt-bench-monitor-a{r}", decode=False))
        runs["decode"].append(rate_decode(frames))
        runs["live"].append(rate_recv(frames, f"tt-bench-monitor-l{r}", decode=True))
    med = {k: statistics.median(v) for k, v in runs.items()}
    return {"decode_frames_per_s": round(med["decode"]), "anchor_frames_per_s": round(med["anchor"]),
            "live_frames_per_s": round(med["live"]), "ratio_vs_anchor": round(med["decode"] / med["anchor"], 3),
            "live_ratio_vs_anchor": round(med["live"] / med["anchor"], 3),
            "keeps_up_8k": min(med["decode"], med["live"]) >= TARGET_FRAMES_PER_S,
            "target_frames_per_s": TARGET_FRAMES_PER_S, "frames": n, "repeats": repeats, "quick": quick,
            "runs_frames_per_s": {k: [round(x) for x in v] for k, v in runs.items()},
            "anchor": "python-can virtual bus recv() of the same frames, same run",
            "mix": "1 ms SYNC cycle: SYNC, 2x TPDO1 (8 B), TPDO5 (master 1 B, slave 8 B); heartbeats and an SDO read every "
                   "100 cycles; an EMCY and its reset every 1000"}


def run(quick: bool, n_frames: int | None = None) -> dict[str, Any]:
    """Measure (``n_frames``: another traffic length, for tests), print the table, write monitor.json."""
    data = measure(quick, n_frames)
    print_table(["measure", "frames/s", "vs anchor"],
                [["python-can recv (anchor)", data["anchor_frames_per_s"], 1.0],
                 ["Monitor.feed (decode)", data["decode_frames_per_s"], data["ratio_vs_anchor"]],
                 ["recv + feed (live)", data["live_frames_per_s"], data["live_ratio_vs_anchor"]]])
    print(f"keeps up with {TARGET_FRAMES_PER_S} frames/s: {data['keeps_up_8k']}")
    print(f"wrote {write_results('monitor', data)}")
    return data


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    run(ap.parse_args().quick)
