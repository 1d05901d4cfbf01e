"""``telethermo rig check [NODE] --rig-config RIG.toml``: commissioning of an I/O rig before a finger goes on
the pad (docs/hardware.md, "Rig check").

The check talks to the I/O modules of the RIG.toml directly (the controller node NODE is not yet trusted:
nothing is written to it): it commissions them as the I/O rig driver would, produces the SYNCs itself and
checks step by step, with small, safe excitations (10 % of limit_A for 1 s), the sampling period of every
module, every signal at rest (present, not at a sentinel: open or shorted sensor, plausible: sign and ×10
scale), the current's polarity and scale (commanded against the monitor), the thermocouple's sign and
scale, the heat sink, and the heat flux's sign (telethermo.iomodule.rigcheck). It stops at the first fault
with one line saying what is wrong and how to fix it (exit 1). NODE's heartbeat is what the modules'
consumer watches (0x1016), as in the session.

With every step passed it prints the figures (exit 0); ``--store`` then saves NODE's parameters
(``telethermo save NODE``, CiA 301 0x1010; NODE up without producing SYNC: ``--no-sync``, no
``--rig io``). The rig's own settings are the RIG.toml, written into the modules by the driver at each
start: the check has nothing of its own to store on the node.

Run it with no controller driving the modules (no other SYNC producer on the bus).
"""

from __future__ import annotations

import argparse
import sys

import canopen

from telethermo.cli import common, store
from telethermo.cli.main import plain_text
from telethermo.iomodule.rigcheck import RigCheck, RigCheckFailed
from telethermo.iomodule.rigconfig import RigConfigError, load_rig_config
from telethermo.remote.errors import Failure, UserError
from telethermo.remote.targets import resolve_node


def register(subparsers) -> None:
    p = subparsers.add_parser("rig", description=__doc__)
    p.set_defaults(func=run)  # an ACTION is required: argparse refuses `telethermo rig` alone (exit 2)
    sub = p.add_subparsers(dest="rig_command", metavar="ACTION", required=True)
    c = sub.add_parser(  # a nested parser: not passed through main's plain_text by the registry
        "check",
        help="verify an I/O rig's wiring step by step (nothing written to NODE)",
        description=plain_text(__doc__ or ""),
    )
    common.add_bus_options(c)
    c.add_argument(
        "node",
        nargs="?",
        default=None,
        metavar="NODE",
        help="the controller node the rig belongs to: master, slave or a node-ID (default: the RIG.toml's "
        "controller, else master)",
    )
    c.add_argument(
        "--rig-config", required=True, metavar="RIG.toml", help="the rig's file (docs/hardware.md)"
    )
    c.add_argument(
        "--store",
        action="store_true",
        help="when every step passed, save NODE's parameters (telethermo save NODE)",
    )
    c.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    c.set_defaults(func=run)


@common.failures
def run(args: argparse.Namespace) -> int:
    net = common.network(args)
    try:
        config = load_rig_config(args.rig_config)
    except RigConfigError as exc:
        raise UserError(str(exc)) from None
    node = args.node or config.controller
    if node is None:
        node = "master"
        print(
            f"rig check: note: no NODE given and {config.source} names no controller: checking it for the "
            'master (give NODE, or controller = "slave" in the file)',
            file=sys.stderr,
        )
    target = resolve_node(net, node)
    say = (lambda _: None) if args.quiet else (lambda text: print(f"rig check: {text}", flush=True))
    with common.canopen_network(args, net) as nw:
        check = RigCheck(
            config,
            nw,
            controller_id=target.node_id,
            period_s=net.sync.period_s,
            counter_overflow=net.sync.counter_overflow,
            sdo_timeout_s=args.timeout,
            progress=say,
        )
        try:
            report = check.run()
        except RigCheckFailed as exc:
            f = exc.finding
            raise Failure(f"check failed at step {f.step} [{f.key}]: {f.line}") from None
        except canopen.SdoAbortedError as exc:
            raise Failure(
                f"{config.source}: a module refused an SDO request: abort 0x{exc.code:08X}"
            ) from None
        except canopen.SdoCommunicationError as exc:
            raise Failure(f"{config.source}: a module stopped answering SDO ({exc})") from None
    for line in report.lines():
        print(f"rig check: {line}")
    print(
        f"rig check: passed: {config.source} is wired as it says ({target.role}, node {target.node_id}); "
        "next: identify, tune, store"
    )
    sys.stdout.flush()
    if args.store:
        return store.run(
            argparse.Namespace(
                **{
                    **vars(args),
                    "nodes": [args.node],
                    "group": "all",
                    "store_command": "save",
                    "command": "save",
                }
            )
        )
    return 0
