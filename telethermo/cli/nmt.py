"""``telethermo nmt``: NMT start / stop / pre-operational / reset for one node or all."""
from __future__ import annotations

import argparse

from telethermo.cli import common
from telethermo.cia301 import NMT_STATES
from telethermo.remote.errors import Failure
from telethermo.remote.heartbeat import heartbeat_wait_s, watch_heartbeats
from telethermo.remote.targets import node_targets, resolve_any_node

#: command -> (NMT command specifier, heartbeat state confirming it)
COMMANDS = {"start": (0x01, 0x05), "stop": (0x02, 0x04), "preop": (0x80, 0x7F),
            "reset": (0x81, 0x00), "reset-comm": (0x82, 0x00)}


def register(subparsers) -> None:
    p = subparsers.add_parser("nmt", description="Send an NMT command and wait for the heartbeat that confirms it "
                                          "(boot-up for the resets). Exit 1 if a node does not confirm.")
    common.add_bus_options(p)
    p.add_argument("command", choices=sorted(COMMANDS), help="start (OPERATIONAL), stop (STOPPED), "
                   "preop (PRE-OPERATIONAL), reset (node), reset-comm (communication)")
    p.add_argument("node", nargs="?", default="all", metavar="NODE", help="master, slave, a node-ID or all (default)")
    p.add_argument("--no-wait", action="store_true", help="do not wait for the confirming heartbeat")
    p.set_defaults(func=run)


@common.failures
def run(args: argparse.Namespace) -> int:
    net = common.network(args)
    cs, want = COMMANDS[args.command]
    targets = node_targets(net) if args.node == "all" else [resolve_any_node(net, args.node)]
    dest = 0 if args.node == "all" else targets[0].node_id
    with common.canopen_network(args, net) as nw:
        hb = watch_heartbeats(nw)
        with hb.cond:
            boots0 = {t.node_id: hb.boot_ups.get(t.node_id, 0) for t in targets}
            counts0 = {t.node_id: hb.count.get(t.node_id, 0) for t in targets}
        nw.send_message(0x000, bytes([cs, dest]))
        if args.no_wait:
            print(f"NMT {args.command} sent to {'all nodes' if dest == 0 else targets[0].role}")
            return 0

        def confirmed(t) -> bool:
            if want == 0x00:
                return hb.boot_ups.get(t.node_id, 0) > boots0[t.node_id]
            s = hb.last.get(t.node_id)
            return s is not None and s[0] == want and hb.count.get(t.node_id, 0) > counts0[t.node_id]

        hb.wait_for(lambda: all(confirmed(t) for t in targets), max(0.5, 3 * heartbeat_wait_s(net)))
        bad = []
        for t in targets:
            ok = confirmed(t)
            state = hb.state_name(t.node_id)
            print(f"{t.role} (node {t.node_id}): {'boot-up seen' if want == 0 and ok else state}"
                  f"{'' if ok else '  (NOT confirmed)'}")
            if not ok:
                bad.append(t.role)
    if bad:
        raise Failure(f"NMT {args.command}: no heartbeat confirming {NMT_STATES[want]} from {', '.join(bad)}")
    return 0
