"""CLI start-up benchmark against the anchors, as ratios measured in one run (interleaved, fresh processes):

    python -m bench.cli_bench [--quick]

- ``telethermo --help`` (the console script a person types) against ``python -m can.viewer --help``;
- one ``telethermo get --bus B master kp_A_per_C`` against a minimal canopen script doing the same SDO read
  (canopen.Network on the same socketcand bus + RemoteNode from the shipped EDS + one ``sdo.upload``), both
  against a live master node process alone on our loopback hub (real time, idle).

Each pair runs back to back, the first of the pair alternating, after one warm-up of each (so the files
are in the page cache for both, and both run from cached bytecode: the children run without
PYTHONDONTWRITEBYTECODE, which this machine's environment sets, so that telethermo's modules, installed
editable from the source tree, get the __pycache__ that pip compiled for the anchors' packages). Ratios
are of the medians (>= 5 each). Writes bench/results/cli.json (keys: help_ratio_vs_can_viewer,
get_ratio_vs_raw_canopen, the four medians in seconds, every run's time, the commands). Target: each
ratio <= 1.5.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from bench.common import print_table, write_results
import struct
from telethermo.bus_config import path as cfg_path
from telethermo.device.eds_info import EdsInfo
from telethermo.nodes.launch import HubProcess, start_lone_node, stop_process, wait_for

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "sim" / "scenes" / "free_pad_identification.toml"
OBJECT = "kp_A_per_C"  # a REAL32 of the master's dictionary

# the anchor of `get`: what a CANopen engineer writes by hand for one SDO read (argv: host port channel
# eds index subindex); prints the raw bytes in hex
RAW_CANOPEN = """\
import sys
import canopen
host, port, channel, eds, index, sub = sys.argv[1:]
network = canopen.Network()
network.connect(interface="socketcand", channel=channel, host=host, port=int(port), tcp_tune=True)
node = canopen.RemoteNode(1, eds)
network.add_node(node)
print(node.sdo.upload(int(index, 0), int(sub, 0)).hex())
network.disconnect()
"""


def telethermo_command() -> list[str]:
    """The console script next to this interpreter (what a user runs), else ``python -m telethermo``."""
    script = Path(sys.executable).with_name("telethermo")
    return [str(script)] if script.exists() else [sys.executable, "-m", "telethermo"]


# the children's environment: bytecode caches written and used, as in a normal installation
CHILD_ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def timed(cmd: list[str]) -> tuple[float, subprocess.CompletedProcess]:
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120, env=CHILD_ENV)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({proc.returncode}): {proc.stderr.strip()[-500:]}")
    return wall, proc


def interleaved(a: list[str], b: list[str], repeats: int) -> tuple[list[float], list[float], str, str]:
    """Run ``a`` and ``b`` ``repeats`` times each, in pairs (the first of a pair alternating), after one
    warm-up of each; return both lists of wall times, s, and the last outputs."""
    out_a, out_b = timed(a)[1].stdout, timed(b)[1].stdout
    ta, tb = [], []
    for i in range(repeats):
        order = [(a, ta), (b, tb)] if i % 2 == 0 else [(b, tb), (a, ta)]
        for cmd, sink in order:
            wall, proc = timed(cmd)
            sink.append(wall)
            if cmd is a:
                out_a = proc.stdout
            else:
                out_b = proc.stdout
    return ta, tb, out_a, out_b


def run(quick: bool = False) -> dict[str, Any]:
    repeats = 5 if quick else 11
    tt = telethermo_command()
    help_tt, help_viewer = tt + ["--help"], [sys.executable, "-m", "can.viewer", "--help"]
    h_tt, h_viewer, _, _ = interleaved(help_tt, help_viewer, repeats)

    eds = cfg_path("master.eds")
    info = EdsInfo(eds).get(OBJECT)
    work = Path(tempfile.mkdtemp(prefix="tt-cli-bench-"))
    hub = HubProcess(log_path=work / "hub.log")
    hub.start()
    node = start_lone_node("master", SCENE, work, "--bus", hub.bus, timing="realtime")
    try:
        get_tt = tt + ["get", "--bus", hub.bus, "master", OBJECT]
        if not wait_for(
            lambda: subprocess.run(get_tt + ["--timeout", "0.3"], capture_output=True).returncode == 0,
            60,
            poll_s=0.2,
        ):
            raise RuntimeError(f"the master node did not answer (see {work})")
        raw = [
            sys.executable,
            "-c",
            RAW_CANOPEN,
            "127.0.0.1",
            str(hub.port),
            hub.bus.rsplit("/", 1)[1],
            str(eds),
            hex(info.index),
            hex(info.subindex),
        ]
        g_tt, g_raw, out_tt, out_raw = interleaved(get_tt, raw, repeats)
    finally:
        stop_process(node)
        hub.stop()
    shutil.rmtree(work, ignore_errors=True)
    # the two read the same thing: the CLI's printed value is the raw script's REAL32
    raw_value = struct.unpack("<f", bytes.fromhex(out_raw.strip()))[0]
    shown = out_tt.split(" = ", 1)[1].split()[0]
    if abs(float(shown) - raw_value) > 1e-4 * max(1.0, abs(raw_value)):
        raise RuntimeError(f"telethermo get printed {out_tt.strip()!r}, the raw canopen read {raw_value}")

    med = statistics.median
    data = {
        "quick": quick,
        "repeats": repeats,
        "object": OBJECT,
        "help_ratio_vs_can_viewer": med(h_tt) / med(h_viewer),
        "get_ratio_vs_raw_canopen": med(g_tt) / med(g_raw),
        "help_median_s": med(h_tt),
        "can_viewer_help_median_s": med(h_viewer),
        "get_median_s": med(g_tt),
        "raw_canopen_get_median_s": med(g_raw),
        "runs_s": {"help": h_tt, "can_viewer_help": h_viewer, "get": g_tt, "raw_canopen_get": g_raw},
        "commands": {
            "help": " ".join(help_tt),
            "can_viewer_help": " ".join(help_viewer),
            "get": " ".join(get_tt),
            "raw_canopen_get": "python -c RAW_CANOPEN (bench/cli_bench.py) "
            "127.0.0.1 PORT telethermo master.eds " + f"{info.index:#06x} {info.subindex}",
        },
        "node": "nodes.master alone on telethermo-hub, --timing realtime --mode idle",
        "bytecode_cache": "children run without PYTHONDONTWRITEBYTECODE (warm-up writes __pycache__)",
        "target_ratio": 1.5,
    }
    _print_ratios(data)
    path = write_results("cli", data)
    print(f"results: {path} (medians of {repeats}, interleaved)")
    return data


def _print_ratios(data: dict[str, Any]) -> None:
    """The two timings against their anchors, s, as a table."""
    print_table(
        ["", "telethermo, s", "anchor, s", "ratio", "target"],
        [
            [
                "--help vs python -m can.viewer --help",
                data["help_median_s"],
                data["can_viewer_help_median_s"],
                data["help_ratio_vs_can_viewer"],
                "<= 1.5",
            ],
            [
                f"get master {OBJECT} vs raw canopen SDO read",
                data["get_median_s"],
                data["raw_canopen_get_median_s"],
                data["get_ratio_vs_raw_canopen"],
                "<= 1.5",
            ],
        ],
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m bench.cli_bench",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--quick", action="store_true", help="5 runs of each instead of 11")
    run(quick=ap.parse_args(argv).quick)
    return 0


if __name__ == "__main__":
    sys.exit(main())
