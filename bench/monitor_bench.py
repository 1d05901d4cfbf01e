"""The monitor's decode rate against python-can's raw receive rate, measured in one run (issue 13: the
monitor must keep up with a full 1 Mbit/s bus, >= 8,000 frames/s):

    python -m bench.monitor_bench [--quick] [--frames N]

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
bench/results/monitor.json. --quick: 20,000 frames, 3 repeats (a few seconds); --frames: another traffic
length (the tests' short run).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from typing import Any

import can

from bench.common import print_table, write_results
from bench.monitor_hub import measure_hub
from telethermo.monitor.traffic import monitor_config, traffic
from telethermo.monitor.state import Monitor

TARGET_FRAMES_PER_S = 8000


def _fill(frames: list[can.Message], channel: str) -> tuple[can.BusABC, can.BusABC]:
    tx = can.Bus(interface="virtual", channel=channel, preserve_timestamps=True)  # bus time of the mix
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
    rate_decode(frames[:2000])  # warm-up: imports, EDS parsing caches
    for r in range(repeats):
        runs["anchor"].append(rate_recv(frames, f"tt-bench-monitor-a{r}", decode=False))
        runs["decode"].append(rate_decode(frames))
        runs["live"].append(rate_recv(frames, f"tt-bench-monitor-l{r}", decode=True))
    med = {k: statistics.median(v) for k, v in runs.items()}
    return {
        "decode_frames_per_s": round(med["decode"]),
        "anchor_frames_per_s": round(med["anchor"]),
        "live_frames_per_s": round(med["live"]),
        "ratio_vs_anchor": round(med["decode"] / med["anchor"], 3),
        "live_ratio_vs_anchor": round(med["live"] / med["anchor"], 3),
        "keeps_up_8k": min(med["decode"], med["live"]) >= TARGET_FRAMES_PER_S,
        "target_frames_per_s": TARGET_FRAMES_PER_S,
        "frames": n,
        "repeats": repeats,
        "quick": quick,
        "runs_frames_per_s": {k: [round(x) for x in v] for k, v in runs.items()},
        "anchor": "python-can virtual bus recv() of the same frames, same run",
        "mix": "1 ms SYNC cycle: SYNC, 2x TPDO1 (8 B), TPDO5 (master 1 B, slave 8 B); heartbeats and an SDO "
        "read every 100 cycles; an EMCY and its reset every 1000",
    }


def run(quick: bool, n_frames: int | None = None) -> dict[str, Any]:
    """Measure (``n_frames``: another traffic length, for tests), print the table, write monitor.json."""
    data = measure(quick, n_frames)
    data.update(measure_hub(*((5_000, 1) if quick else (30_000, 5))))
    print_table(
        ["measure", "frames/s", "vs anchor"],
        [
            ["python-can recv (anchor)", data["anchor_frames_per_s"], 1.0],
            ["Monitor.feed (decode)", data["decode_frames_per_s"], data["ratio_vs_anchor"]],
            ["recv + feed (live)", data["live_frames_per_s"], data["live_ratio_vs_anchor"]],
            ["hub: socketcand recv (anchor)", data["hub_anchor_frames_per_s"], 1.0],
            ["hub: recv + feed (live)", data["hub_live_frames_per_s"], data["hub_live_ratio_vs_anchor"]],
        ],
    )
    data["hub_keeps_up_8k"] = (
        data["hub_live_frames_per_s"] >= TARGET_FRAMES_PER_S and data["hub_frames_lost"] == 0
    )
    print(
        f"keeps up with {TARGET_FRAMES_PER_S} frames/s: {data['keeps_up_8k']} (virtual), "
        f"{data['hub_keeps_up_8k']} (live over the hub)"
    )
    print(f"wrote {write_results('monitor', data)}")
    return data


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.monitor_bench", description=__doc__.splitlines()[0])
    ap.add_argument(
        "--quick", action="store_true", help="20,000 frames, 3 repeats; the hub: 5,000 frames, once"
    )
    ap.add_argument(
        "--frames", type=int, default=None, help="traffic length (default: 20,000 quick, else 100,000)"
    )
    args = ap.parse_args(argv)
    run(args.quick, args.frames)
    return 0


if __name__ == "__main__":
    sys.exit(main())
