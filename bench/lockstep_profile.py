"""Where a lockstep cycle goes (issue 12): ``python -m bench.lockstep_profile [--cycles N]``.

Runs the raw ping-pong anchor (bench.raw_anchor) and then the in-process virtual lockstep run of the nodes
benchmark (bench.nodes_bench.lockstep_virtual: both node runtimes, simulated rigs, recording on) with an
inclusive wall-clock timer (``time.perf_counter``) around a fixed list of functions of the cycle, and prints
per function: calls, microseconds per lockstep cycle (summed over both nodes) and per call. Inclusive:
a row contains the rows of the functions it calls (``ControlCycle.run`` contains ``step``). The timers
add about 1 us per call, so the lockstep run is a few percent slower than without them.

A diagnostic, not a result: it writes no file; docs/nodes.md quotes one run. cProfile is not used for
the table because its per-call overhead (several us) inflates the many small functions of the cycle
2-3x; it is still the tool to find a new hotspot (``python -m cProfile`` sees one thread only).
"""

from __future__ import annotations

import argparse
import functools
import importlib
import logging
import sys
import tempfile
import time
from pathlib import Path

from bench.nodes_bench import anchor_virtual, lockstep_virtual

#: (module, qualified name): the lockstep cycle's parts, outermost first
TIMED = (
    ("telethermo.device.sync", "SyncProducer.transmit"),  # master: SYNC out + its own SYNC processing
    ("telethermo.device.sync_consumer", "SyncConsumer.process"),  # both: RPDO commit, SYNC handlers, TPDOs
    ("telethermo.nodes.cycle", "ControlCycle.run"),  # both: one control cycle
    ("telethermo.nodes.cycle", "step"),  # telethermo.control.core.step
    ("telethermo.nodes.cycle", "ControlCycle._inputs"),  # rig advance + read, peer values
    ("telethermo.sim.rig", "SimRig.advance"),
    ("telethermo.nodes.cycle", "ControlCycle._record"),  # the CSV row (incl. the rig's truth)
    ("telethermo.sim.rig", "SimRig.truth"),
    ("telethermo.recording.journal", "CsvRecorder.write"),
    ("telethermo.nodes.cycle", "ControlCycle._publish"),  # ~13 OD writes
    ("telethermo.device.pdo_engine", "PdoEngine.send_sync_tpdos"),
    ("telethermo.device.pdo_engine", "PdoEngine._on_rpdo_frame"),
    ("telethermo.transport.resilient", "ResilientBus.send"),  # every frame a node sends
    ("can.interfaces.virtual", "VirtualBus.send"),  # python-can (the anchor pays it too)
    ("canopen.network", "Network.notify"),  # canopen's receive dispatch (incl. handlers)
    ("telethermo.nodes.producer", "_PeerDebt.wait"),  # master: waiting for the slave's PDOs
)


class Timers:
    """perf_counter wrappers around TIMED; ``take()`` returns and clears {name: [calls, seconds]}."""

    def __init__(self) -> None:
        self.acc: dict[str, list] = {}
        self._undo: list[tuple[object, str, object]] = []

    def install(self) -> None:
        for modname, qual in TIMED:
            owner = importlib.import_module(modname)
            *path, attr = qual.split(".")
            for p in path:
                owner = getattr(owner, p)
            fn = getattr(owner, attr)
            self._undo.append((owner, attr, fn))
            setattr(owner, attr, self._wrap(qual, fn))

    def _wrap(self, key: str, fn):
        acc, clock = self.acc, time.perf_counter
        acc[key] = [0, 0.0]

        @functools.wraps(fn)
        def timed(*args, **kwargs):
            t0 = clock()
            try:
                return fn(*args, **kwargs)
            finally:
                e = acc[key]
                e[0] += 1
                e[1] += clock() - t0

        return timed

    def uninstall(self) -> None:
        for owner, attr, fn in reversed(self._undo):
            setattr(owner, attr, fn)
        self._undo.clear()

    def take(self) -> dict[str, list]:
        out = {k: list(v) for k, v in self.acc.items() if v[0]}
        for v in self.acc.values():
            v[0], v[1] = 0, 0.0
        return out


def _table(title: str, per_s: float, cycles: int, acc: dict[str, list]) -> None:
    print(f"{title}: {per_s:.0f} cycles/s = {1e6 / per_s:.0f} us per cycle")
    for name, (calls, secs) in sorted(acc.items(), key=lambda kv: -kv[1][1]):
        print(
            f"  {name:34s} {calls:7d} calls {secs * 1e6 / cycles:8.1f} us/cycle "
            f"{secs * 1e6 / calls:8.1f} us/call"
        )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m bench.lockstep_profile",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--cycles", type=int, default=3000, help="cycles of each run (default 3000)")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.ERROR)
    timers = Timers()
    timers.install()
    try:
        a = anchor_virtual(args.cycles, f"profile-anchor-{time.monotonic_ns()}")[0]
        _table("raw ping-pong anchor, virtual", a, args.cycles, timers.take())
        with tempfile.TemporaryDirectory(prefix="lockstep_profile_") as d:
            res = lockstep_virtual(args.cycles, Path(d), "profile")
        _table("lockstep, virtual (1 process)", res["cycles_per_s"], args.cycles, timers.take())
    finally:
        timers.uninstall()
    print(f"ratio {res['cycles_per_s'] / a:.2f} (with the timers)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
