"""The anchor of the nodes benchmark: a raw python-can ping-pong over the same transport as the nodes,
no canopen, no control, no recording (issue 12, "speed as a ratio").

One cycle is the frames a lockstep node cycle puts on the bus, sent and received with nothing but
python-can: the pinger (the master's place) sends SYNC (COB-ID 0x080, 1 byte: the counter, as
0x1019 = 240 gives) and its own TPDO1 (0x181, 8 bytes) and TPDO5 (0x681, 1 byte: the contact flag);
the responder (the slave's place) answers each SYNC with its TPDO1 (0x182, 8 bytes) and TPDO5 (0x682,
8 bytes: the contact flag and its identified material) and ignores everything else; the pinger sends the next
SYNC once the responder's last frame (0x682) is in, as the lockstep master waits for the slave's last
synchronous RPDO. Not in the anchor: the status TPDOs every 10th SYNC and the heartbeats (a node's own work).

The node benchmark divides its lockstep cycles/s by the anchor's, measured in the same run on the same
transport: ``lockstep_ratio_vs_raw_virtual`` (responder in a thread of this process, python-can's
``virtual`` bus, as the in-process node benchmark) and ``lockstep_ratio_vs_raw_hub`` (responder in
another process, our socketcand hub, as the two node processes).

``python -m bench.raw_anchor --respond BUS`` is the responder process (until SIGTERM or its stdin
closes); it prints ``ready`` once its bus is open.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import threading
import time

import can
from telethermo.nodes.children import readline_within
from telethermo.nodes.launch import HubProcess
from telethermo.transport.bus import TransportSettings, open_bus, parse_bus_string

SYNC_ID = 0x080
OUT_FRAMES = ((0x181, 8), (0x681, 1))  # the pinger's own TPDO1, TPDO5 (master, node 1)
BACK_FRAMES = ((0x182, 8), (0x682, 8))  # the responder's TPDO1, TPDO5 (slave, node 2: flag + identification)
LAST_BACK_ID = BACK_FRAMES[-1][0]
COUNTER_OVERFLOW = 240


def _frames(frames) -> list[can.Message]:
    return [
        can.Message(arbitration_id=cob, data=bytes(range(1, n + 1)), is_extended_id=False)
        for cob, n in frames
    ]


def respond(bus: can.BusABC, stop: threading.Event) -> int:
    """Answer every SYNC with the responder's frames until ``stop``; return the SYNCs answered."""
    back = _frames(BACK_FRAMES)
    n = 0
    while not stop.is_set():
        msg = bus.recv(0.1)
        if msg is not None and msg.arbitration_id == SYNC_ID:
            for m in back:
                bus.send(m)
            n += 1
    return n


def ping(bus: can.BusABC, cycles: int, *, timeout_s: float = 5.0) -> float:
    """Run ``cycles`` ping-pong cycles; return cycles/s (wall time of the loop, perf_counter)."""
    out = _frames(OUT_FRAMES)
    sync = can.Message(arbitration_id=SYNC_ID, data=b"\x01", is_extended_id=False)
    counter = 0
    t0 = time.perf_counter()
    for _ in range(cycles):
        counter = counter % COUNTER_OVERFLOW + 1
        sync.data[0] = counter
        bus.send(sync)
        for m in out:
            bus.send(m)
        while True:
            msg = bus.recv(timeout_s)
            if msg is None:
                raise RuntimeError(f"raw anchor: no answer to SYNC {counter} within {timeout_s} s")
            if msg.arbitration_id == LAST_BACK_ID:
                break
    return cycles / (time.perf_counter() - t0)


def anchor_virtual(cycles: int, channel: str) -> float:
    """Cycles/s of the ping-pong on python-can's virtual bus, the responder in a thread of this process."""
    return anchor_virtual_cpu(cycles, channel)[0]


def anchor_virtual_cpu(cycles: int, channel: str) -> tuple[float, float]:
    """As :func:`anchor_virtual`: (cycles/s, CPU time of this process per cycle, s: both ends, every thread,
    ``time.process_time``; less sensitive than wall time to other processes' load on shared cores)."""
    settings = TransportSettings("virtual", channel)
    a, b = open_bus(settings), open_bus(settings)
    stop = threading.Event()
    t = threading.Thread(target=respond, args=(b, stop), name="raw-responder", daemon=True)
    t.start()
    try:
        ping(a, 10)  # both ends up
        c0 = time.process_time()
        rate = ping(a, cycles)
        return rate, (time.process_time() - c0) / cycles
    finally:
        stop.set()
        t.join(5)
        a.shutdown()
        b.shutdown()


def anchor_process(cycles: int, bus: str) -> float:
    """Cycles/s of the ping-pong over ``bus`` (e.g. our hub), the responder in another process."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "bench.raw_anchor", "--respond", bus],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        line = readline_within(proc, 30.0)
        if line.strip() != "ready":
            raise RuntimeError(f"raw anchor responder did not start: {line.strip() or 'no output'}")
        mine = open_bus(parse_bus_string(bus))
        try:
            time.sleep(0.3)  # the hub holds a new raw-mode client's first 0.2 s of frames back
            ping(mine, 10)
            return ping(mine, cycles)
        finally:
            mine.shutdown()
    finally:
        proc.stdin.close()  # the responder ends when its stdin closes
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def _responder_main(bus_text: str) -> int:
    bus = open_bus(parse_bus_string(bus_text))
    stop = threading.Event()

    def watch_stdin() -> None:
        sys.stdin.read()
        stop.set()

    threading.Thread(target=watch_stdin, daemon=True).start()
    print("ready", flush=True)
    try:
        respond(bus, stop)
    finally:
        bus.shutdown()
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m bench.raw_anchor",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--respond", metavar="BUS", help="run the responder on BUS until stdin closes")
    ap.add_argument("--cycles", type=int, default=3000, help="ping-pong cycles (default 3000)")
    args = ap.parse_args(argv)
    if args.respond:
        return _responder_main(args.respond)
    print(f"virtual: {anchor_virtual(args.cycles, f'anchor-{time.monotonic_ns()}'):.0f} cycles/s")
    hub = HubProcess()
    hub.start()
    try:
        print(f"hub: {anchor_process(args.cycles, hub.bus):.0f} cycles/s")
    finally:
        hub.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
