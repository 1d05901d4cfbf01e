"""``telethermo nmt``: NMT start / stop / pre-operational / reset for one node or all.

A command is confirmed by a heartbeat reporting the state it asked (boot-up for the resets), seen in any
heartbeat since it was sent; then the command listens for one more heartbeat: a node that left the state
again (e.g. a slave put into PRE-OPERATIONAL, which the pair's SYNC producer, its NMT master, starts again
at its next heartbeat: docs/nodes.md) is reported with the other NMT master's command and how long after,
exit 1, since the state asked does not hold."""

from __future__ import annotations

import argparse

from telethermo.cli import common
from telethermo.cia301 import NMT_STATES
from telethermo.remote.errors import Failure
from telethermo.remote.heartbeat import heartbeat_wait_s, watch_heartbeats
from telethermo.remote.targets import node_targets, resolve_any_node

#: command -> (NMT command specifier, heartbeat state confirming it)
COMMANDS = {
    "start": (0x01, 0x05),
    "stop": (0x02, 0x04),
    "preop": (0x80, 0x7F),
    "reset": (0x81, 0x00),
    "reset-comm": (0x82, 0x00),
}


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "nmt",
        description="Send an NMT command and wait for the heartbeat that confirms it "
        "(boot-up for the resets). Exit 1 if a node does not confirm.",
    )
    common.add_bus_options(p)
    p.add_argument(
        "nmt_command",
        metavar="command",
        choices=sorted(COMMANDS),
        help="start (OPERATIONAL), stop (STOPPED), "
        "preop (PRE-OPERATIONAL), reset (node), reset-comm (communication)",
    )
    p.add_argument(
        "node", nargs="?", default="all", metavar="NODE", help="master, slave, a node-ID or all (default)"
    )
    p.add_argument("--no-wait", action="store_true", help="do not wait for the confirming heartbeat")
    p.set_defaults(func=run)


@common.failures
def run(args: argparse.Namespace) -> int:
    net = common.network(args)
    cs, want = COMMANDS[args.nmt_command]
    targets = node_targets(net) if args.node == "all" else [resolve_any_node(net, args.node)]
    dest = 0 if args.node == "all" else targets[0].node_id
    with common.canopen_network(args, net) as nw:
        hb = watch_heartbeats(nw)
        with hb.cond:
            boots0 = {t.node_id: hb.boot_ups.get(t.node_id, 0) for t in targets}
            counts0 = {t.node_id: hb.count.get(t.node_id, 0) for t in targets}
        nw.send_message(0x000, bytes([cs, dest]))
        if args.no_wait:
            print(f"NMT {args.nmt_command} sent to {'all nodes' if dest == 0 else targets[0].role}")
            return 0

        def confirmed(t) -> bool:
            if want == 0x00:
                return hb.boot_ups.get(t.node_id, 0) > boots0[t.node_id]
            return any(st == want for st, _ in hb.states.get(t.node_id, [])[counts0[t.node_id] :])

        hb.wait_for(lambda: all(confirmed(t) for t in targets), max(0.5, 3 * heartbeat_wait_s(net)))
        ok = {t.node_id: confirmed(t) for t in targets}
        if want != 0x00:  # does it hold? one more heartbeat of each confirmed node
            with hb.cond:
                seen = {t.node_id: hb.count.get(t.node_id, 0) for t in targets}
            hb.wait_for(
                lambda: all(hb.count.get(t.node_id, 0) > seen[t.node_id] for t in targets if ok[t.node_id]),
                heartbeat_wait_s(net),
            )
        bad, left = [], []
        for t in targets:
            state = hb.state_name(t.node_id)
            print(
                f"{t.role} (node {t.node_id}): {'boot-up seen' if want == 0 and ok[t.node_id] else state}"
                f"{'' if ok[t.node_id] else '  (NOT confirmed)'}"
            )
            if not ok[t.node_id]:
                bad.append(t.role)
            elif want != 0x00 and hb.last[t.node_id][0] != want:
                left.append(_left_again(hb, t, want, counts0[t.node_id]))
    if bad:
        raise Failure(
            f"NMT {args.nmt_command}: no heartbeat confirming {NMT_STATES[want]} from {', '.join(bad)}"
        )
    if left:
        raise Failure("; ".join(left))
    return 0


def _left_again(hb, t, want: int, since: int) -> str:
    """One line: the node reported ``want``, then left it, and who commanded it (another NMT master)."""
    with hb.cond:
        states = hb.states.get(t.node_id, [])[since:]
        reached = next(ts for st, ts in states if st == want)
        now = states[-1][0]
        other = [(ts, cs) for ts, cs, node in hb.nmt if node in (0, t.node_id) and ts >= reached]
    why = ""
    if other:
        ts, cs = other[0]
        name = next((n for n, (c, _) in COMMANDS.items() if c == cs), f"0x{cs:02X}")
        why = (
            f": another NMT master sent NMT {name} {max(0.0, ts - reached) * 1e3:.0f} ms after its "
            f"{NMT_STATES[want]} heartbeat (the pair's SYNC producer starts a node that reports "
            f"PRE-OPERATIONAL or a boot-up: docs/nodes.md)"
        )
    return (
        f"{t.role} (node {t.node_id}) reported {NMT_STATES[want]}, then {NMT_STATES.get(now, hex(now))}"
        f"{why}; it does not stay there"
    )
