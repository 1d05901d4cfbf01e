"""``telethermo sdo NODE INDEX[:SUB] [VALUE] [--type T]``: SDO upload or download with any node on the bus.

For the devices a bench has beside ours (a robot arm, I/O modules, thermocouple amplifiers): any node-ID
1..127, with or without an EDS, through canopen's SdoClient (expedited or segmented, as the size asks).
Without VALUE: an upload, shown as ``--type`` says, else as the node's EDS says (our nodes), else as raw
bytes with the unsigned and text readings that fit. With VALUE: a download of VALUE encoded as ``--type``
(or the EDS type of our nodes). Nothing is range-checked here (``set`` does that): the node decides, and
its refusal is printed with the CiA 301 text of its abort code (exit 1).
"""

from __future__ import annotations

import argparse
import re

from canopen.sdo.exceptions import SdoAbortedError, SdoCommunicationError

from telethermo.cli import common
from telethermo.cli.main import UserError
from telethermo.remote import codec, values
from telethermo.remote.codec import EDS_TYPES, TYPES, decode_as, encode_as, raw_text
from telethermo.remote.client import remote_node
from telethermo.remote.errors import Failure, abort_text
from telethermo.remote.targets import eds_info, resolve_any_node


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "sdo",
        description="SDO upload (read) or, with VALUE, download (write) of one object of "
        "any node 1..127, with or without an EDS. INDEX is hex (0x1018 or "
        "1018), SUB decimal or 0x.. (default 0). A refusal shows the abort "
        "code and its CiA 301 meaning (exit 1); nothing is range-checked "
        "here (`set` does that).",
    )
    common.add_bus_options(p)
    p.add_argument("node", metavar="NODE", help="node-ID 1..127 (decimal or 0x..), or master/slave")
    p.add_argument("object", metavar="INDEX[:SUB]", help="e.g. 0x1018:1, 1017, 0x2000:0")
    p.add_argument(
        "value", metavar="VALUE", nargs="?", help="write this value (needs --type for a node without EDS)"
    )
    p.add_argument(
        "--type",
        choices=list(TYPES),
        metavar="TYPE",
        help=f"how to encode/decode the value: {'|'.join(TYPES)} (default: the EDS type of our nodes; "
        "an upload without one shows the raw bytes)",
    )
    p.set_defaults(func=run)


def parse_object(text: str) -> tuple[int, int]:
    """``0x1018:1`` / ``1018:1`` / ``0x1018sub1`` / ``0x1018`` -> (index, sub); UserError otherwise."""
    m = re.fullmatch(r"\s*(?:0x)?([0-9A-Fa-f]{1,4})(?:(?::|sub|\.)(0x[0-9A-Fa-f]{1,2}|\d{1,3}))?\s*", text)
    sub = int(m.group(2), 0) if m and m.group(2) else 0
    if not m or sub > 0xFF:
        raise UserError(
            f"object {text!r}: expected INDEX[:SUB], INDEX hex 0x0000..0xFFFF (e.g. 0x1018:1), SUB 0..255"
        )
    return int(m.group(1), 16), sub


@common.failures
def run(args: argparse.Namespace) -> int:
    net = common.network(args)
    t = resolve_any_node(net, args.node)
    index, sub = parse_object(args.object)
    where = f"0x{index:04X}:{sub:02X}"
    info = None
    if t.eds is not None:
        info = eds_info(t).vars.get((index, sub))
    type_name = args.type or (EDS_TYPES.get(info.data_type) if info is not None else None)
    data = None
    if args.value is not None:
        if type_name is None:
            raise UserError(
                f"{t.role} {where}: give --type ({'|'.join(TYPES)}) to write: "
                + ("no EDS object there" if t.eds is not None else "no EDS for this node")
            )
        data = encode_as(type_name, args.value)
    with common.canopen_network(args, net) as nw:
        node = remote_node(nw, t.node_id, args.timeout)
        try:
            if data is None:
                got = node.sdo.upload(index, sub)
            else:
                node.sdo.download(index, sub, data)
        except SdoAbortedError as exc:
            verb = "read" if data is None else "write"
            raise Failure(f"{t.role} {where}: {verb} refused: {abort_text(exc.code)}") from None
        except SdoCommunicationError as exc:
            raise Failure(
                f"{t.role} {where}: no answer (SDO timeout {args.timeout:g} s; is node "
                f"{t.node_id} on the bus?) ({exc})"
            ) from None
    name = f" {info.key}" if info is not None else ""
    if data is not None:
        print(f"{t.role} {where}{name} <- {data.hex(' ')} ({TYPES[type_name][1]} {args.value}): written")
    elif args.type:
        print(f"{t.role} {where}{name} = {decode_as(args.type, got)}")
    elif info is not None:
        print(f"{t.role} {where}{name} = {values.fmt(codec.decode(info, got), info, eds_info(t))}")
    else:
        print(f"{t.role} {where} = {raw_text(got)}")
    return 0
