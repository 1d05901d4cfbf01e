"""``telethermo find``: which CANopen nodes are on the bus (heartbeats, identity 0x1018, name 0x1008)."""

from __future__ import annotations

import argparse
import json
import struct
import sys

from canopen.sdo.exceptions import SdoAbortedError, SdoCommunicationError

from telethermo.cli import common
from telethermo.cia301 import NMT_UNKNOWN
from telethermo.remote.client import remote_node
from telethermo.remote.errors import Failure
from telethermo.remote.heartbeat import heartbeat_wait_s, watch_heartbeats
from telethermo.remote.targets import node_targets


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "find",
        description="Listen for heartbeats, probe the configured node-IDs (or all "
        "1..127 with --scan) by SDO, and read identity (0x1018) and device "
        "name (0x1008) of every node that answers. Exit 1 if none is found.",
    )
    common.add_bus_options(p)
    p.add_argument(
        "--scan", action="store_true", help="probe every node-ID 1..127, not only the configured ones"
    )
    p.add_argument("--json", action="store_true", help="one JSON document on stdout")
    p.set_defaults(func=run)


def _read(node, index: int, sub: int):
    try:
        return node.sdo.upload(index, sub)
    except (SdoAbortedError, SdoCommunicationError):
        return None


@common.failures
def run(args: argparse.Namespace) -> int:
    net = common.network(args)
    configured = {t.node_id: t for t in node_targets(net)}
    with common.canopen_network(args, net) as nw:
        hb = watch_heartbeats(nw)
        if args.scan:
            nw.scanner.search()  # SDO upload 0x1000 to all node-IDs at once; servers answer
        hb.wait_for(lambda: False, heartbeat_wait_s(net))
        candidates = sorted(set(hb.last) | set(configured) | set(nw.scanner.nodes if args.scan else []))
        found = []
        for nid in candidates:
            t = configured.get(nid)
            node = remote_node(nw, nid, min(args.timeout, 0.5))
            dtype = _read(node, 0x1000, 0)
            state = hb.state_name(nid)
            if dtype is None and state == NMT_UNKNOWN:
                continue  # configured but silent: not on the bus
            ident = [_read(node, 0x1018, s) for s in (1, 2, 3, 4)]
            name = _read(node, 0x1008, 0)
            found.append(
                {
                    "node_id": nid,
                    "role": t.role if t else None,
                    "nmt_state": state,
                    "heartbeats": hb.count.get(nid, 0),
                    "answers_sdo": dtype is not None,
                    "device_type": struct.unpack("<I", dtype)[0] if dtype and len(dtype) == 4 else None,
                    "vendor_id": _u32(ident[0]),
                    "product_code": _u32(ident[1]),
                    "revision": _u32(ident[2]),
                    "serial": _u32(ident[3]),
                    "device_name": name.decode("ascii", "replace").rstrip("\x00") if name else None,
                }
            )
    if args.json:
        print(
            json.dumps(
                {
                    "nodes": found,
                    "missing": [
                        configured[n].role for n in configured if n not in {f["node_id"] for f in found}
                    ],
                },
                indent=2,
            )
        )
    else:
        if found:
            print(
                f"{'NODE':>4} {'ROLE':7} {'NMT':16} {'VENDOR':>10} {'PRODUCT':>10} {'REV':>10} "
                f"{'SERIAL':>10}  NAME"
            )
        for f in found:
            h = lambda v: "-" if v is None else f"0x{v:08X}"  # noqa: E731
            print(
                f"{f['node_id']:4d} {f['role'] or '-':7} {f['nmt_state']:16} {h(f['vendor_id']):>10} "
                f"{h(f['product_code']):>10} {h(f['revision']):>10} {h(f['serial']):>10}  "
                f"{f['device_name'] or '(no SDO answer)'}"
            )
        for n, t in configured.items():
            if n not in {f["node_id"] for f in found}:
                print(f"{n:4d} {t.role:7} not found (no heartbeat, no SDO answer)", file=sys.stderr)
    if not found:
        raise Failure("no CANopen node found on the bus")
    return 0


def _u32(b):
    return struct.unpack("<I", b)[0] if b and len(b) == 4 else None
