"""The live monitor's sustained receive rate over the hub, next to python-can's raw receive rate over the
same hub, in one run (issue 13: the monitor keeps up with a full bus, >= 8,000 frames/s):

    python -m bench.monitor_hub [--frames N] [--repeats R]

A hub process (``telethermo-hub``, socketcand protocol on loopback) carries the traffic mix of
:mod:`telethermo.monitor.traffic`, sent as fast as one sender process can (``--send``: a separate process, so
that its work does not share the receiver's interpreter). The receiver, in this process, is either

- the anchor: python-can's ``socketcand`` client and ``bus.recv()`` alone, or
- the live monitor's path: the same bus opened the way the monitor opens it
  (:func:`telethermo.transport.bus.open_bus`), ``recv()`` then :meth:`Monitor.feed` per frame.

The hub never drops a frame for a slow client (it buffers), so the receiver's rate from its first to its
last frame is what it sustains; the sender is shared by both, so a sender slower than the anchor shows
as an anchor rate close to the monitor's (then the figure only says "at least").
"""

from __future__ import annotations

import argparse
import logging
import statistics
import subprocess
import sys
import time

import can

from telethermo.monitor.traffic import monitor_config, traffic
from telethermo.monitor.state import Monitor
from telethermo.nodes.children import readline_within
from telethermo.nodes.launch import HubProcess
from telethermo.transport.bus import open_bus, parse_bus_string

# python-can's socketcand client logs every TCP read that splits a frame
# (a warning per few frames at this rate)
logging.getLogger("can.interfaces.socketcand").setLevel(logging.ERROR)

GRACE_S = (
    0.5  # longer than the hub's join grace (0.2 s): the receiver is in raw mode before the sender starts
)


def _sender_main(bus_text: str, n_frames: int) -> int:
    """Open ``bus_text``, say ready, wait for a line on stdin, send the mix's ``n_frames`` frames."""
    frames = [
        can.Message(arbitration_id=m.arbitration_id, data=m.data, is_extended_id=False)
        for m in traffic(n_frames)
    ]
    bus = open_bus(parse_bus_string(bus_text))
    try:
        print("ready", flush=True)
        sys.stdin.readline()
        for m in frames:
            bus.send(m)
        print("sent", flush=True)
        sys.stdin.readline()  # keep the connection until the receiver has everything
    finally:
        bus.shutdown()
    return 0


def receive_rate(bus_text: str, n_frames: int, *, decode: bool, timeout_s: float = 60.0) -> tuple[float, int]:
    """(frames/s from the first to the last frame, frames received) for one receiver over ``bus_text``."""
    rx = open_bus(parse_bus_string(bus_text))
    sender = subprocess.Popen(
        [sys.executable, "-m", "bench.monitor_hub", "--send", bus_text, "--frames", str(n_frames)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    mon = Monitor(monitor_config()) if decode else None
    got, t_first, t_last = 0, 0.0, 0.0
    try:
        assert sender.stdout is not None and sender.stdin is not None
        if readline_within(sender, 30.0).strip() != "ready":
            raise RuntimeError("the sender process did not start")
        time.sleep(GRACE_S)
        sender.stdin.write("go\n")
        sender.stdin.flush()
        deadline = time.monotonic() + timeout_s
        while got < n_frames and time.monotonic() < deadline:
            m = rx.recv(1.0)
            if m is None:
                continue
            t_last = time.perf_counter()
            if got == 0:
                t_first = t_last
            got += 1
            if mon is not None:
                mon.feed(m)
        return (got - 1) / (t_last - t_first) if got > 1 else 0.0, got
    finally:
        rx.shutdown()
        try:
            sender.communicate("done\n", timeout=10)
        except subprocess.TimeoutExpired:
            sender.kill()
            sender.wait()


def measure_hub(n_frames: int, repeats: int) -> dict:
    """Anchor and monitor receive rates over one hub process, interleaved, medians of ``repeats``."""
    hub = HubProcess()
    hub.start()
    runs: dict[str, list[float]] = {"anchor": [], "live": []}
    lost = 0
    try:
        for _ in range(repeats):
            for name, decode in (("anchor", False), ("live", True)):
                rate, got = receive_rate(hub.bus, n_frames, decode=decode)
                runs[name].append(rate)
                lost += n_frames - got
    finally:
        hub.stop()
    med = {k: statistics.median(v) for k, v in runs.items()}
    return {
        "hub_anchor_frames_per_s": round(med["anchor"]),
        "hub_live_frames_per_s": round(med["live"]),
        "hub_live_ratio_vs_anchor": round(med["live"] / med["anchor"], 3) if med["anchor"] else None,
        "hub_frames_lost": lost,
        "hub_frames": n_frames,
        "hub_repeats": repeats,
        "hub_runs_frames_per_s": {k: [round(x) for x in v] for k, v in runs.items()},
        "hub_anchor": "python-can socketcand client recv() over the same hub process, same run; one sender "
        "process sending the mix as fast as it can",
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.monitor_hub", description=__doc__.splitlines()[0])
    ap.add_argument("--send", metavar="BUS", help="run as the sender process on BUS")
    ap.add_argument("--frames", type=int, default=30_000)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    if args.send:
        return _sender_main(args.send, args.frames)
    data = measure_hub(args.frames, args.repeats)
    for k, v in data.items():
        print(f"{k}: {v}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
