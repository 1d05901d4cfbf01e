"""``telethermo fault-reset``: the operator's fault reset (object 0x240A fault_reset).

A trip of the safety envelope other than a peer loss stays latched (current cut, EMCY, 0x1001 bit)
until the operator clears it. Writing 1 to 0x240A makes the node clear, at its next SYNC, the latched
trips whose cause is gone; while a cause persists the node refuses the write (SDO abort 0x08000022) and
clears nothing. This command writes it, then reads the safety state back.
"""

from __future__ import annotations

import argparse
import time

from telethermo.cia301 import ABORT_DEVICE_STATE
from telethermo.cli import common
from telethermo.control.safety import trips_from_mask
from telethermo.remote import values
from telethermo.remote.client import NodeClient
from telethermo.remote.errors import Failure, Refused, UserError, abort_text
from telethermo.remote.targets import Target, lookup, pair_targets, resolve_node


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "fault-reset",
        description="The operator's fault reset (object 0x240A): each node clears the latched "
        "trips whose cause is gone, with their EMCYs, and its envelope restarts "
        "bumplessly from the surface. A node where a cause persists refuses "
        "(abort 0x08000022) and clears nothing: exit 1, with the trip named.",
    )
    common.add_bus_options(p)
    p.add_argument(
        "nodes",
        nargs="*",
        metavar="NODE",
        help="master, slave or a node-ID (default: the master and the slave of the network file)",
    )
    p.set_defaults(func=run)


def _read(node: NodeClient, t: Target, key: str):
    info = lookup(t, key)
    return info, node.read(info)


def _persists(node: NodeClient, before: dict) -> str:
    """Why the node refused: the trips blocking the reset (fault_reset_blocked_by), the last trip and the
    error register."""
    t = node.t
    trip_info, trip = before["last_trip_code"]
    reg_info, reg = before["0x1001"]
    why = ""
    try:
        mask = node.read(lookup(t, "fault_reset_blocked_by"))
        why = ", ".join(tr.value for tr in trips_from_mask(int(mask)))
    except (Failure, UserError):
        pass  # an older node: the last trip and the error register still say a lot
    return (
        f"{t.role}: a latched fault persists{f' ({why})' if why else ''}: last trip "
        f"{values.fmt(trip, trip_info, node.eds)}, error register "
        f"{values.fmt(reg, reg_info, node.eds)}; remove its cause, then reset"
    )


def _safety(info, code: int) -> str:
    """The safety state's name as the EDS describes it (``current cut``)."""
    return (values.enum_names(info, ours=False) or {}).get(code, str(code))


@common.failures
def run(args: argparse.Namespace) -> int:
    net = common.network(args)
    targets = [resolve_node(net, n) for n in args.nodes] if args.nodes else pair_targets(net)
    for t in targets:
        lookup(t, "fault_reset")
    refused = []
    with common.canopen_network(args, net) as nw:
        for t in targets:
            node = NodeClient(nw, t, args.timeout)
            info = lookup(t, "fault_reset")
            before = {k: _read(node, t, k) for k in ("safety_state", "last_trip_code", "0x1001")}
            try:
                node.write(info, 1)
            except Refused as exc:
                if exc.code != ABORT_DEVICE_STATE:
                    raise Failure(
                        f"{t.role} (node {t.node_id}) refused the fault reset: {abort_text(exc.code)}"
                    ) from None
                refused.append(_persists(node, before))
                print(f"{t.role} (node {t.node_id}): not reset, {abort_text(exc.code)}")
                continue
            # taken at the node's next SYNC: read the state back for a while
            deadline = time.monotonic() + 2.0
            while True:
                st = node.read(before["safety_state"][0])
                reg = node.read(before["0x1001"][0])
                if (st != 3 and reg == 0) or time.monotonic() > deadline:
                    break
                time.sleep(0.05)
            (st_info, was), reg_info = before["safety_state"], before["0x1001"][0]
            print(
                f"{t.role} (node {t.node_id}): "
                f"safety {_safety(st_info, was)} -> {_safety(st_info, st)} ({st}), "
                f"error register {values.fmt(reg, reg_info, node.eds)}"
            )
    if refused:
        raise Failure("; ".join(refused))
    return 0
