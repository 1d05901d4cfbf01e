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
import struct
from typing import Any

from canopen.sdo.exceptions import SdoAbortedError, SdoCommunicationError

from telethermo.cli import common
from telethermo.cli.main import UserError
from telethermo.remote import codec, values
from telethermo.remote.client import remote_node
from telethermo.remote.errors import Failure, abort_text
from telethermo.remote.targets import Target, eds_info, node_targets, resolve_node

#: --type -> (struct format or None for text, CiA 301 type name)
TYPES: dict[str, tuple[str | None, str]] = {
    "u8": ("<B", "UNSIGNED8"), "u16": ("<H", "UNSIGNED16"), "u32": ("<I", "UNSIGNED32"), "u64": ("<Q", "UNSIGNED64"),
    "i8": ("<b", "INTEGER8"), "i16": ("<h", "INTEGER16"), "i32": ("<i", "INTEGER32"), "i64": ("<q", "INTEGER64"),
    "f32": ("<f", "REAL32"), "f64": ("<d", "REAL64"), "str": (None, "VISIBLE_STRING"),
}
#: CiA 301 data type code of an EDS entry -> --type
EDS_TYPES = {0x0001: "u8", 0x0002: "i8", 0x0003: "i16", 0x0004: "i32", 0x0005: "u8", 0x0006: "u16", 0x0007: "u32",
             0x0008: "f32", 0x0009: "str", 0x0011: "f64", 0x0015: "i64", 0x001B: "u64"}


def register(subparsers) -> None:
    p = subparsers.add_parser("sdo", description="SDO upload (read) or, with VALUE, download (write) of one object of "
                                                 "any node 1..127, with or without an EDS. INDEX is hex (0x1018 or "
                                                 "1018), SUB decimal or 0x.. (default 0). A refusal shows the abort "
                                                 "code and its CiA 301 meaning (exit 1); nothing is range-checked "
                                                 "here (`set` does that).")
    common.add_bus_options(p)
    p.add_argument("node", metavar="NODE", help="node-ID 1..127 (decimal or 0x..), or master/slave")
    p.add_argument("object", metavar="INDEX[:SUB]", help="e.g. 0x1018:1, 1017, 0x2000:0")
    p.add_argument("value", metavar="VALUE", nargs="?", help="write this value (needs --type for a node without EDS)")
    p.add_argument("--type", choices=list(TYPES), metavar="TYPE",
                   help=f"how to encode/decode the value: {'|'.join(TYPES)} (default: the EDS type of our nodes; "
                        "an upload without one shows the raw bytes)")
    p.set_defaults(func=run)


def parse_object(text: str) -> tuple[int, int]:
    """``0x1018:1`` / ``1018:1`` / ``0x1018sub1`` / ``0x1018`` -> (index, sub); UserError otherwise."""
    m = re.fullmatch(r"\s*(?:0x)?([0-9A-Fa-f]{1,4})(?:(?::|sub|\.)(0x[0-9A-Fa-f]{1,2}|\d{1,3}))?\s*", text)
    sub = int(m.group(2), 0) if m and m.group(2) else 0
    if not m or sub > 0xFF:
        raise UserError(f"object {text!r}: expected INDEX[:SUB], INDEX hex 0x0000..0xFFFF (e.g. 0x1018:1), "
                        "SUB 0..255")
    return int(m.group(1), 16), sub


def target_of(net, text: str) -> Target:
    """A node of the network file (by name or ID, with its EDS), or any other node-ID 1..127 (no EDS)."""
    try:
        return resolve_node(net, text)
    except UserError:
        try:
            node_id = int(text, 0)
        except ValueError:
            node_id = None
        if node_id is None or not 1 <= node_id <= 127:
            names = ", ".join(t.role for t in node_targets(net))
            raise UserError(f"node {text!r}: expected a node-ID 1..127 or one of {names}") from None
        return Target(f"node {node_id}", node_id, None)


def encode(type_name: str, text: str) -> bytes:
    """VALUE as the bytes of ``type_name``; UserError naming what was expected."""
    fmt, cia = TYPES[type_name]
    if fmt is None:
        try:
            return text.encode("ascii")
        except UnicodeEncodeError:
            raise UserError(f"value {text!r}: expected ASCII text for a {cia}") from None
    try:
        value: Any = float(text) if type_name.startswith("f") else int(text, 0)
    except ValueError:
        raise UserError(f"value {text!r}: expected a {'number' if type_name.startswith('f') else 'whole number'} "
                        f"for a {cia}") from None
    try:
        return struct.pack(fmt, value)
    except (struct.error, OverflowError):
        size = struct.calcsize(fmt)
        lo, hi = (0, (1 << 8 * size) - 1) if type_name.startswith("u") else (-(1 << 8 * size - 1), (1 << 8 * size - 1) - 1)
        raise UserError(f"value {text}: does not fit a {cia} ({lo}..{hi})") from None


def decode(type_name: str, data: bytes) -> str:
    """The uploaded bytes read as ``type_name``; Failure if their size does not fit."""
    fmt, cia = TYPES[type_name]
    if fmt is None:
        return repr(data.decode("ascii", "replace").rstrip("\x00"))
    if len(data) != struct.calcsize(fmt):
        raise Failure(f"the node sent {len(data)} bytes ({data.hex(' ')}); a {cia} has {struct.calcsize(fmt)}")
    v = struct.unpack(fmt, data)[0]
    if type_name.startswith("f"):
        return repr(v)
    return f"{v} (0x{v & ((1 << 8 * len(data)) - 1):0{2 * len(data)}X})"


def raw(data: bytes) -> str:
    """Bytes of unknown type: hex, and the unsigned little-endian and ASCII readings that fit."""
    text = f"{data.hex(' ') or '(no data)'} ({len(data)} byte{'s' if len(data) != 1 else ''}"
    if len(data) in (1, 2, 4, 8):
        v = int.from_bytes(data, "little")
        text += f"; as u{8 * len(data)} {v} = 0x{v:0{2 * len(data)}X}"
    stripped = data.rstrip(b"\x00")
    if len(stripped) >= 3 and all(32 <= b < 127 for b in stripped):   # a byte or two is rarely text
        text += f"; as text {stripped.decode('ascii')!r}"
    return text + ")"


@common.failures
def run(args: argparse.Namespace) -> int:
    net = common.network(args)
    t = target_of(net, args.node)
    index, sub = parse_object(args.object)
    where = f"0x{index:04X}:{sub:02X}"
    info = None
    if t.eds is not None:
        info = eds_info(t).vars.get((index, sub))
    type_name = args.type or (EDS_TYPES.get(info.data_type) if info is not None else None)
    data = None
    if args.value is not None:
        if type_name is None:
            raise UserError(f"{t.role} {where}: give --type ({'|'.join(TYPES)}) to write: "
                            + ("no EDS object there" if t.eds is not None else "no EDS for this node"))
        data = encode(type_name, args.value)
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
            raise Failure(f"{t.role} {where}: no answer (SDO timeout {args.timeout:g} s; is node "
                          f"{t.node_id} on the bus?) ({exc})") from None
    name = f" {info.key}" if info is not None else ""
    if data is not None:
        print(f"{t.role} {where}{name} <- {data.hex(' ')} ({TYPES[type_name][1]} {args.value}): written")
    elif args.type:
        print(f"{t.role} {where}{name} = {decode(args.type, got)}")
    elif info is not None:
        print(f"{t.role} {where}{name} = {values.fmt(codec.decode(info, got), info, eds_info(t))}")
    else:
        print(f"{t.role} {where} = {raw(got)}")
    return 0
