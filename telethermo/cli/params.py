"""``telethermo get`` / ``telethermo set``: parameters by their EDS name, with units and ranges."""

from __future__ import annotations

import argparse

from telethermo.bus_config.partable import BY_NAME
from telethermo.cia301 import ABORT_TOO_HIGH, ABORT_TOO_LOW
from telethermo.cli import common, live_writes
from telethermo.cli.main import UserError
from telethermo.remote import values
from telethermo.remote.client import NodeClient
from telethermo.remote.errors import Failure, Refused
from telethermo.remote.targets import Target, eds_info, lookup, resolve_node
from telethermo.remote.values import check_range, parse_value


def register(subparsers) -> None:
    g = subparsers.add_parser(
        "get",
        description="Read parameters of a node by SDO, by their EDS name "
        "(kp_A_per_C, theta3, 'Identity object.Vendor-ID') or number "
        "(0x2200, 0x1018:1). --list shows every object with unit and range.",
    )
    common.add_bus_options(g)
    # NODE is checked in run_get: argparse would name NAME as required too, though --list needs none
    g.add_argument("node", nargs="?", metavar="NODE", help="master, slave or a node-ID")
    g.add_argument("names", nargs="*", metavar="NAME")
    g.add_argument(
        "--list", action="store_true", help="list the node's objects (from its EDS; no bus needed)"
    )
    g.set_defaults(func=run_get)
    s = subparsers.add_parser(
        "set",
        description="Write one parameter of a node by SDO. A value outside the EDS "
        "range is refused here (exit 2, nothing sent); a write the node "
        "refuses shows the SDO abort code and its meaning (exit 1). A safety "
        "limit that a node driving current already breaks (its trip would cut "
        "the current) is refused unless --force; a gain says which mode's "
        "gain it wrote (each mode keeps its own).",
    )
    common.add_bus_options(s)
    s.add_argument("node", metavar="NODE", help="master, slave or a node-ID")
    s.add_argument("name", metavar="NAME")
    s.add_argument("value", metavar="VALUE")
    s.add_argument(
        "--force",
        action="store_true",
        help="send a safety limit that the node's present readings already break (its trip then cuts "
        "the current at the next cycle); without it such a write is refused, nothing sent",
    )
    s.set_defaults(func=run_set)


def describe(info) -> str:
    """Type, access and range; for an operator parameter (bus_config/partable.py) what a write changes
    (its scope: per mode, all modes, RENDER, IDENTIFY, node) and whether a store (0x1010) keeps it."""
    rng = info.range_text() or "no range"
    p = BY_NAME.get(info.key)
    if p is None or p.index != info.index:
        return f"{info.type_name}, {info.access}, {rng}"
    return f"{info.type_name}, {info.access}, {rng}, {p.scope}{'' if p.stored else ', not stored'}"


def where(info) -> str:
    """``0x2200`` for a VAR object, ``0x1018:01`` for an entry of an ARRAY/RECORD."""
    return (
        f"0x{info.index:04X}"
        if info.key == info.name and info.subindex == 0
        else f"0x{info.index:04X}:{info.subindex:02X}"
    )


def line(t: Target, info, value, eds) -> str:
    """One value as ``get``/``set`` print it: node, object, name, value with unit (or hex, or name)."""
    return f"{t.role} {where(info)} {info.key} = {values.fmt(value, info, eds)}    ({describe(info)})"


def refusal(exc: Refused, node, t: Target, info, eds) -> str:
    """The node's refusal with the rule that refused: a value out of the node's own range (its EDS is
    narrower than ours), else the object's description and the current values of the objects it names."""
    text = str(exc)
    if exc.code in (ABORT_TOO_HIGH, ABORT_TOO_LOW):
        return (
            f"{text}; the node's limit is narrower than this EDS's range {info.range_text() or '(none)'} "
            f"({info.key} in {eds_info(t).path}: out of date?)"
        )
    if not info.description:
        return text
    now = []
    for key in values.rule_keys(info, eds):
        other = eds.by_key[key]
        try:
            now.append(f"{key} = {values.fmt(node.read(other), other, eds)}")
        except Failure:
            pass  # the rule is still worth saying without the current value
    return f"{text}; {info.key}: {info.description}" + (f" (now {', '.join(now)})" if now else "")


@common.failures
def run_get(args: argparse.Namespace) -> int:
    net = common.network(args)
    if args.node is None:
        raise UserError(
            "give a NODE (master, slave or a node-ID)"
            + ("" if args.list else " and at least one parameter NAME, or --list")
        )
    t = resolve_node(net, args.node)
    if args.list:
        eds = eds_info(t)
        for (index, sub), v in sorted(eds.vars.items()):
            print(
                f"0x{index:04X}:{sub:02X} {v.key:45s} {v.type_name:10s} {v.access:5s} "
                f"{v.range_text() or '-':28s} {v.description}"
            )
        return 0
    if not args.names:
        raise UserError("give at least one parameter NAME, or --list")
    infos = [lookup(t, n) for n in args.names]
    eds = eds_info(t)
    with common.canopen_network(args, net) as nw:
        node = NodeClient(nw, t, args.timeout)
        for info in infos:
            print(line(t, info, node.read(info), eds))
    return 0


@common.failures
def run_set(args: argparse.Namespace) -> int:
    net = common.network(args)
    t = resolve_node(net, args.node)
    info = lookup(t, args.name)
    if not info.writable:
        raise UserError(
            f"{info.key} is {'read-only' if info.access in ('ro', 'const') else info.access}; not sent"
        )
    code = values.parse_enum(info, args.value)  # `set master mode telepresence`
    names = values.enum_names(info)
    try:
        value = code if code is not None else parse_value(info, args.value)
    except UserError:
        if not names:
            raise
        listed = ", ".join(f"{n} ({c})" for c, n in names.items())
        raise UserError(f"{info.key}: expected one of {listed}, got {args.value!r}") from None
    check_range(info, value)
    eds = eds_info(t)
    with common.canopen_network(args, net) as nw:
        node = NodeClient(nw, t, args.timeout)
        effect = live_writes.judge(node, t, info.key, value)
        if effect is not None and effect.cut and not args.force:
            raise UserError(f"{effect.text}; not sent: a safety limit the node already breaks needs --force")
        try:
            node.write(info, value)
        except Refused as exc:
            raise Failure(refusal(exc, node, t, info, eds)) from None
        back = node.read(info) if "r" in info.access else value
        note = live_writes.gain_note(node, t, info.key)
    print(line(t, info, back, eds))
    if effect is not None:
        print(f"  {effect.text}")
    if note is not None:
        print(note)
    return 0
