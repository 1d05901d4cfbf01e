"""Real-time robustness under load (issue 12): the two node programs at 100 Hz in real time over our hub,
with one busy process per core beside them and an operator's CLI command (``telethermo status``) every few
seconds, for 10 minutes (``--duration``). Figures: peer-lost trips (EMCY 0x8130 on the bus, from either
node), the late-cycle fraction and the SYNC->TPDO latency (median and p99) of the master, and the same pair
on the quiet machine for a short run in the same session as the baseline.

    python -m bench.realtime_bench [--duration S] [--no-rt]
        # -> bench/results/realtime.json (realtime_no_rt.json with --no-rt)

Not a timed test: a benchmark. The nodes run with the real-time options a lab would use (``--rt-priority
50 --gc freeze``; ``--no-rt`` runs without them, to see what they buy).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import threading
from pathlib import Path
from typing import Any

from bench.common import write_results
from bench.nodes_bench import SCENE, _Observer
from telethermo.cia301 import EMCY_HEARTBEAT
from telethermo.nodes.launch import NodePair, PairConfig

RT_ARGS = ["--rt-priority", "50", "--gc", "freeze"]
CLI_EVERY_S = 3.0


def _burners(n: int) -> list[subprocess.Popen]:
    """n processes that keep one core busy each."""
    return [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(n)]


class _Operator(threading.Thread):
    """``telethermo status`` against the running pair every CLI_EVERY_S seconds (a person at the CLI)."""

    def __init__(self, bus: str) -> None:
        super().__init__(daemon=True)
        self.bus, self.stop_event, self.runs, self.failures = bus, threading.Event(), 0, 0

    def run(self) -> None:
        while not self.stop_event.wait(CLI_EVERY_S):
            p = subprocess.run(
                [sys.executable, "-m", "telethermo", "status", "--bus", self.bus, "--timeout", "1"],
                capture_output=True,
                text=True,
                timeout=60,
            )
            self.runs += 1
            self.failures += p.returncode != 0


def _emcy_heartbeat(frames: list[tuple[float, int, bytes]]) -> int:
    """EMCY 0x8130 (peer lost) frames of either node seen on the bus."""
    return sum(
        1
        for _, cob, d in frames
        if 0x081 <= cob <= 0x0FF and len(d) >= 2 and int.from_bytes(bytes(d[:2]), "little") == EMCY_HEARTBEAT
    )


def run_pair(duration_s: float, folder: Path, *, load: bool, rt: bool) -> dict[str, Any]:
    """The pair in real time for ``duration_s``, with or without the load; its figures."""
    cycles = int(round(duration_s / 0.01))
    node_args = ["--wait-peer", "600", *(RT_ARGS if rt else [])]
    pair = NodePair(
        PairConfig(
            scene=SCENE,
            out_dir=folder,
            timing="realtime",
            cycles=cycles,
            seed=0,
            master_args=node_args,
            slave_args=RT_ARGS if rt else [],
        )
    )
    burners = _burners(os.cpu_count() or 2) if load else []
    operator = None
    try:
        with pair:
            obs = _Observer(pair.hub.port)
            if load:
                operator = _Operator(pair.bus)
                operator.start()
            code = pair.wait_master(timeout_s=duration_s * 3 + 120)
            frames = obs.log.snapshot()
            obs.close()
    finally:
        if operator is not None:
            operator.stop_event.set()
        for b in burners:
            b.kill()
            b.wait()
        pair.stop()
    if code != 0 or pair.result is None:
        raise RuntimeError(f"real-time run failed (master exit {code}); logs in {folder}")
    r = pair.result
    return {
        "duration_s": duration_s,
        "load": load,
        "rt_options": rt,
        "cycles": r.cycles,
        "peer_lost_trips": _emcy_heartbeat(frames),
        "master_peer_losses": r.peer["losses"],
        "late_cycles": r.late_cycles,
        "late_fraction": r.late_cycles / max(1, r.cycles),
        "latency_p50_ms": r.sync_to_tpdo_ms_p50,
        "latency_p99_ms": r.sync_to_tpdo_ms_p99,
        "cli_commands": operator.runs if operator else 0,
        "cli_failures": operator.failures if operator else 0,
        "load_average_end": list(os.getloadavg()),
    }


def run(duration_s: float = 600.0, rt: bool = True, baseline_s: float = 30.0) -> dict[str, Any]:
    with tempfile.TemporaryDirectory(prefix="realtime_bench_") as tmp:
        quiet = run_pair(baseline_s, Path(tmp) / "quiet", load=False, rt=rt)
        loaded = run_pair(duration_s, Path(tmp) / "loaded", load=True, rt=rt)
    out = {
        "peer_lost_trips_10min_loaded": loaded["peer_lost_trips"] if duration_s >= 600 else None,
        "peer_lost_trips_loaded": loaded["peer_lost_trips"],
        "late_fraction": loaded["late_fraction"],
        "latency_p99_ms": loaded["latency_p99_ms"],
        "loaded": loaded,
        "quiet_baseline": quiet,
        "how": f"100 Hz real time over the hub, {os.cpu_count()} busy processes beside the pair, telethermo "
        f"status every {CLI_EVERY_S:g} s; node options {' '.join(RT_ARGS) if rt else 'none'}",
    }
    print(
        f"loaded {duration_s:g} s: peer-lost trips {loaded['peer_lost_trips']}, "
        f"late {loaded['late_cycles']} of {loaded['cycles']} ({100 * loaded['late_fraction']:.2f} %), "
        f"SYNC->TPDO p50 {loaded['latency_p50_ms']} ms p99 {loaded['latency_p99_ms']} ms, "
        f"{loaded['cli_commands']} CLI commands ({loaded['cli_failures']} failed); "
        f"quiet {baseline_s:g} s: late {100 * quiet['late_fraction']:.2f} %, p99 {quiet['latency_p99_ms']} ms"
    )
    print(f"wrote {write_results('realtime' if rt else 'realtime_no_rt', out)}")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.realtime_bench", description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=600.0, metavar="S", help="loaded run, s (default 600)")
    ap.add_argument("--no-rt", action="store_true", help="run the nodes without the real-time options")
    args = ap.parse_args(argv)
    run(args.duration, rt=not args.no_rt)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
