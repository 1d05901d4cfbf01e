"""``telethermo-iomodule``: one simulated CiA 401 analog I/O module as its own process (docs/hardware.md).

    telethermo-iomodule --node-id 3 --scene pads_in_air --side master --bus socketcand://127.0.0.1:PORT/vcan0

The module boots into PRE-OPERATIONAL (boot-up message, heartbeat 0x1017) and waits to be configured and
started by an NMT master, as a real module does; its plant (the ``--side`` rig of ``--scene``) advances
with the SYNCs it receives. Exit codes: 0 stopped by SIGINT/SIGTERM, 1 the bus cannot be opened,
2 bad option or file (one line naming it).
"""

from __future__ import annotations

import argparse
import logging
import sys
import threading
from pathlib import Path

import canopen

from telethermo.device import DeviceSettings, NetworkConfigError, load_network
from telethermo.iomodule.faults import FaultError, Faults, parse_faults
from telethermo.iomodule.module import IoModule
from telethermo.iomodule.truthlog import TruthLog
from telethermo.sim.compile import build_rig
from telethermo.sim.errors import SceneError
from telethermo.rig import SimulatedRig
from telethermo.sim.scene import load_scene
from telethermo.stopsignal import StopOnSignal
from telethermo.transport.bus import TransportError, TransportSettings
from telethermo.transport.busargs import add_bus_arguments
from telethermo.transport.resilient import ResilientBus
from telethermo.transport.resolve import resolve_bus

PROG = "telethermo-iomodule"
EXIT_OK, EXIT_FAIL, EXIT_USAGE = 0, 1, 2
DEFAULT_NODE_ID = 3


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog=PROG,
        description="A simulated CiA 401 analog I/O module (CANopen node) "
        "with "
        "a simulated rig behind its channels.",
    )
    p.add_argument(
        "--node-id", type=int, default=DEFAULT_NODE_ID, help=f"node-ID 1..127 (default {DEFAULT_NODE_ID})"
    )
    p.add_argument(
        "--scene", default="pads_in_air", help="scene name or TOML file of the plant (default pads_in_air)"
    )
    p.add_argument(
        "--side",
        choices=("master", "slave"),
        default="master",
        help="which rig of the scene is wired to the channels (default master)",
    )
    p.add_argument("--seed", type=int, help="sensor-noise seed (default: the scene's)")
    p.add_argument(
        "--network", help="network settings file: bus, SYNC period and counter (default: packaged)"
    )
    p.add_argument(
        "--fault",
        action="append",
        default=[],
        metavar="KIND:ARGS",
        help="inject a wiring fault (repeatable): sign:N, sign:out, scale:N:F, open:N, short:N, "
        "swap:A:B, sampling:MS, detach:S (telethermo.iomodule.faults)",
    )
    p.add_argument(
        "--record",
        type=Path,
        metavar="FILE.csv",
        help="write the simulated plant's truth per SYNC into FILE.csv (telethermo session --io)",
    )
    add_bus_arguments(p)
    p.add_argument("-v", "--verbose", action="store_true", help="log state changes on stderr")
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format=f"%(asctime)s {PROG} %(levelname)s %(message)s",
        stream=sys.stderr,
    )
    logging.getLogger("can.interfaces.socketcand.socketcand").setLevel(logging.ERROR)
    if not 1 <= args.node_id <= 127:
        print(f"{PROG}: error: --node-id: expected 1..127, got {args.node_id}", file=sys.stderr)
        return EXIT_USAGE
    try:
        net = load_network(args.network)
        transport = resolve_bus(
            net, bus=args.bus, interface=args.interface, channel=args.channel, bitrate=args.bitrate
        ).settings
        rig = build_rig(load_scene(args.scene), args.side, seed=args.seed)
        faults = parse_faults(args.fault)
        if faults.detach_at_s is not None:
            rig.detach_sensor(faults.detach_at_s)
    except (NetworkConfigError, TransportError, SceneError, FaultError) as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as exc:
        print(f"{PROG}: error: --scene {args.scene}: {exc.strerror or exc}", file=sys.stderr)
        return EXIT_USAGE
    settings = DeviceSettings(
        sync_period_us=round(net.sync.period_s * 1e6), sync_counter_overflow=net.sync.counter_overflow
    )
    stop = threading.Event()
    with StopOnSignal(stop):
        return _serve(transport, args, rig, settings, faults, stop)


def _serve(
    transport: TransportSettings,
    args: argparse.Namespace,
    rig: SimulatedRig,
    settings: DeviceSettings,
    faults: Faults,
    stop: threading.Event,
) -> int:
    """Open the bus, run the module until ``stop`` is set (SIGINT/SIGTERM), close it; the exit code."""
    try:
        bus = ResilientBus(transport)
    except Exception as exc:  # no hub, no interface: the module cannot start
        print(f"{PROG}: error: cannot open {transport.describe()}: {exc}", file=sys.stderr)
        return EXIT_FAIL
    network = canopen.Network(bus)
    network.connect()
    module = IoModule(network, args.node_id, rig, settings=settings, faults=faults)
    try:
        truth = TruthLog(args.record, rig, args.side) if args.record is not None else None
    except OSError as exc:
        print(f"{PROG}: error: --record {args.record}: {exc.strerror or exc}", file=sys.stderr)
        network.disconnect()
        return EXIT_USAGE
    if truth is not None:  # after the module's own handler: the plant has advanced
        module.device.add_sync_handler(truth.on_sync)
    try:
        module.start()
        logging.getLogger("telethermo.iomodule").info(
            "node %d on %s: pre-operational", args.node_id, transport.describe()
        )
        # one line a launcher waits for (telethermo.nodes.iomodules): the module answers from now on
        print(f"{PROG} node {args.node_id} ready on {transport.describe()}", flush=True)
        while not stop.wait(0.5):
            pass
    finally:
        module.close()
        network.disconnect()
        if truth is not None:
            truth.close()
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
