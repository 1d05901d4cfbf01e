"""Lockstep SYNC (DESIGN.md §3): SYNC k+1 only after the peer's PDO of cycle k arrived.

The producer's own PDO of cycle k is sent inside :meth:`SyncProducer.transmit` (own tick), so
waiting for the peer's RPDO is enough. A cycle whose peer PDO does not come within ``timeout_s``
is reported (``step()`` returns False) and counted, never hidden: the node decides what a missing
PDO means (the safety envelope's peer-loss path).

``python -m telethermo.canopen_dev.lockstep`` measures the device layer alone: two devices on a
python-can ``virtual`` bus in one process, a trivial SYNC handler, N lockstep cycles; it prints the
median cycles/s over repeats (the node programs add their control step and rig on top), and the
median cost of one SYNC on a lone device (``process_sync_us``; ``sync_transmit_us`` with the SYNC
frame itself).
"""
from __future__ import annotations

import argparse
import statistics
import time
import uuid

from telethermo.canopen_dev.device import Device
from telethermo.canopen_dev.sync import SyncProducer


class LockstepDriver:
    """Drives lockstep cycles from the SYNC-producing device."""

    def __init__(self, device: Device, sync: SyncProducer | None = None, *, rpdo: int = 1, timeout_s: float = 1.0):
        self.device = device
        self.sync = sync or SyncProducer(device)
        self.rpdo = rpdo
        self.timeout_s = timeout_s
        self.cycles = 0
        self.missed = 0

    def step(self) -> bool:
        """One cycle: SYNC (own tick included), then wait for the peer's PDO. False if it did not come."""
        before = self.device.rpdo_count(self.rpdo)
        self.sync.transmit()
        self.cycles += 1
        if self.device.wait_rpdo(self.rpdo, after=before, timeout=self.timeout_s):
            return True
        self.missed += 1
        return False


def measure_virtual(cycles: int = 2000, *, repeats: int = 3) -> dict[str, float]:
    """Median lockstep cycles/s of two bare devices over python-can ``virtual`` (one process)."""
    import canopen

    from bus_config import path
    from telethermo.canopen_dev.device import NmtCommand
    from telethermo.canopen_dev.netconfig import load_network

    cfg = load_network()
    rates = []
    for _ in range(repeats):
        channel = f"lockstep-{uuid.uuid4().hex[:8]}"
        nets, devs = [], []
        try:
            for role in ("master", "slave"):
                net = canopen.Network()
                net.NOTIFIER_CYCLE = 0.05
                net.connect(interface="virtual", channel=channel)
                nets.append(net)
                dev = Device(net, cfg.node(role).node_id, path(f"{role}.eds"), settings=cfg.device_settings(role))
                devs.append(dev)
                write, read = dev.writer("estimate_C"), dev.reader("peer_estimate_C")
                dev.add_sync_handler(lambda tick, w=write, r=read: w(r() + 1.0))
                dev.start()
            devs[0].nmt_command(NmtCommand.START, 0)
            driver = LockstepDriver(devs[0], timeout_s=5.0)
            for _ in range(50):  # warm-up
                driver.step()
            t0 = time.perf_counter()
            for _ in range(cycles):
                driver.step()
            rates.append(cycles / (time.perf_counter() - t0))
            if driver.missed:
                raise RuntimeError(f"{driver.missed} cycles without the peer's PDO")
        finally:
            for dev in devs:
                dev.close()
            for net in nets:
                net.disconnect()
    return {"lockstep_cycles_per_s_device_virtual": statistics.median(rates), "cycles": cycles,
            "repeats": repeats, "min": min(rates), "max": max(rates)}


def measure_per_sync(n: int = 5000, *, repeats: int = 5) -> dict[str, float]:
    """Median cost of one SYNC on a lone producing device (own tick, handler, TPDO1 sent), µs."""
    import canopen

    from bus_config import path
    from telethermo.canopen_dev.device import NmtCommand

    net = canopen.Network()
    net.NOTIFIER_CYCLE = 0.05
    net.connect(interface="virtual", channel=f"persync-{uuid.uuid4().hex[:8]}")
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
    parser = argparse.ArgumentParser(description="Lockstep cycles/s of two bare devices over python-can virtual, "
                                                 "and the cost of one SYNC on one device.")
    parser.add_argument("--cycles", type=int, default=2000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    result = {**measure_virtual(args.cycles, repeats=args.repeats), **measure_per_sync(repeats=args.repeats)}
    print(" ".join(f"{k}={v:.1f}" if isinstance(v, float) else f"{k}={v}" for k, v in result.items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
