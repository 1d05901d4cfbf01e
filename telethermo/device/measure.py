"""Speed of the device layer alone: ``python -m telethermo.device.measure``.

Two bare devices on a python-can ``virtual`` bus in one process, a trivial SYNC handler on each
(``estimate = peer + 1``), N cycles of SYNC k+1 after the peer's PDO k; it prints the median cycles/s
over repeats (the node programs add their control step and rig on top), and the median cost of one
SYNC on a lone device (``process_sync_us``; ``sync_transmit_us`` with the SYNC frame itself).
"""

from __future__ import annotations

import argparse
import statistics
import time
import uuid
from typing import Any, Callable

import canopen

from telethermo.bus_config import path
from telethermo.device.device import Device, NmtCommand
from telethermo.device.events import SyncTick
from telethermo.device.netconfig import load_network
from telethermo.device.sync import SyncProducer


def _virtual_network(channel: str) -> canopen.Network:
    net = canopen.Network()
    net.NOTIFIER_CYCLE = 0.05
    net.connect(interface="virtual", channel=channel)
    return net


def _cycles(master: Device, sync: SyncProducer, n: int, timeout_s: float) -> int:
    """``n`` cycles: SYNC (own tick included), then wait for the peer's RPDO1; the cycles it did not come."""
    missed = 0
    for _ in range(n):
        before = master.rpdo_count(1)
        sync.transmit()
        if not master.wait_rpdo(1, after=before, timeout=timeout_s):
            missed += 1
    return missed


def measure_virtual(cycles: int = 2000, *, repeats: int = 3) -> dict[str, float]:
    """Median cycles/s of two bare devices over python-can ``virtual`` (one process)."""
    cfg = load_network()
    rates = []
    for _ in range(repeats):
        channel = f"lockstep-{uuid.uuid4().hex[:8]}"
        nets, devs = [], []
        try:
            for role in ("master", "slave"):
                nets.append(net := _virtual_network(channel))
                dev = Device(
                    net, cfg.node(role).node_id, path(f"{role}.eds"), settings=cfg.device_settings(role)
                )
                devs.append(dev)
                write, read = dev.writer("estimate_C"), dev.reader("peer_estimate_C")

                def relay(
                    tick: SyncTick, w: Callable[[Any], None] = write, r: Callable[[], Any] = read
                ) -> None:
                    w(r() + 1.0)

                dev.add_sync_handler(relay)
                dev.start()
            devs[0].nmt_command(NmtCommand.START, 0)
            sync = SyncProducer(devs[0])
            _cycles(devs[0], sync, 50, 5.0)  # warm-up
            t0 = time.perf_counter()
            missed = _cycles(devs[0], sync, cycles, 5.0)
            rates.append(cycles / (time.perf_counter() - t0))
            if missed:
                raise RuntimeError(f"{missed} cycles without the peer's PDO")
        finally:
            for dev in devs:
                dev.close()
            for net in nets:
                net.disconnect()
    return {
        "lockstep_cycles_per_s_device_virtual": statistics.median(rates),
        "cycles": cycles,
        "repeats": repeats,
        "min": min(rates),
        "max": max(rates),
    }


def measure_per_sync(n: int = 5000, *, repeats: int = 5) -> dict[str, float]:
    """Median cost of one SYNC on a lone producing device (own tick, handler, TPDO1 sent), µs."""
    net = _virtual_network(f"persync-{uuid.uuid4().hex[:8]}")
    dev = Device(net, 1, path("master.eds"))
    try:
        write, read = dev.writer("estimate_C"), dev.reader("peer_estimate_C")
        dev.add_sync_handler(lambda tick: write(read() + 1.0))
        dev.start()
        dev.nmt_command(NmtCommand.START, 0)
        sync = SyncProducer(dev)
        own, transmit = [], []
        for _ in range(repeats):
            t0 = time.perf_counter()
            for _ in range(n):
                dev.process_sync(1)
            t1 = time.perf_counter()
            for _ in range(n):
                sync.transmit()
            t2 = time.perf_counter()
            own.append((t1 - t0) / n * 1e6)
            transmit.append((t2 - t1) / n * 1e6)
    finally:
        dev.close()
        net.disconnect()
    return {"process_sync_us": statistics.median(own), "sync_transmit_us": statistics.median(transmit)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description="Lockstep cycles/s of two bare devices over python-can virtual, "
        "and the cost of one SYNC on one device."
    )
    parser.add_argument("--cycles", type=int, default=2000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    result = {**measure_virtual(args.cycles, repeats=args.repeats), **measure_per_sync(repeats=args.repeats)}
    print(" ".join(f"{k}={v:.1f}" if isinstance(v, float) else f"{k}={v}" for k, v in result.items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
