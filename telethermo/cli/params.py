"""``telethermo get`` / ``telethermo set``: parameters by their EDS name, with units and ranges."""
from __future__ import annotations

import argparse

from telethermo.cli import common
from telethermo.cli.main import UserError


def register(subparsers) -> None:
    g = subparsers.add_parser("get", description="Read parameters of a node by SDO, by their EDS name "
                                          "(kp_A_per_C, theta3, 'Identity object.Vendor-ID') or number "
                                          "(0x2200, 0x1018:1). --list shows every object with unit and range.")
    common.add_bus_options(g)
    g.add_argument("node", metavar="NODE", help="master, slave or a node-ID")
    g.add_argument("names", nargs="*", metavar="NAME")
    g.add_argument("--list", action="store_true", help="list the node's objects (from its EDS; no bus needed)")
    g.set_defaults(func=run_get)
    s = subparsers.add_parser("set", description="Write one parameter of a node by SDO. A value outside the EDS "
                                          "range is refused here (exit 2, nothing sent); a write the node "
                                          "refuses shows the SDO abort code and its meaning (exit 1).")
    common.add_bus_options(s)
    s.add_argument("node", metavar="NODE", help="master, slave or a node-ID")
    s.add_argument("name", metavar="NAME")
    s.add_argument("value", metavar="VALUE")
    s.set_defaults(func=run_set)


def describe(info) -> str:
    rng = info.range_text() or "no range"
    return f"{info.type_name}, {info.access}, {rng}, 0x{info.index:04X}:{info.subindex:02X}"


@common.failures
def run_get(args: argparse.Namespace) -> int:
    net = common.network(args)
    t = common.resolve_node(net, args.node)
    if args.list:
        eds = common.eds_info(t)
        for (index, sub), v in sorted(eds.vars.items()):
            print(f"0x{index:04X}:{sub:02X} {v.key:45s} {v.type_name:10s} {v.access:5s} "
                  f"{v.range_text() or '-':28s} {v.description}")
        return 0
    if not args.names:
        raise UserError("give at least one parameter NAME, or --list")
    infos = [common.lookup(t, n) for n in args.names]
    with common.canopen_network(args, net) as nw:
        node = common.remote(nw, t, args.timeout)
        for info in infos:
            v = common.sdo_read(node, t, info)
            print(f"{info.key} = {common.fmt(v, info)}    ({describe(info)})")
    return 0


@common.failures
def run_set(args: argparse.Namespace) -> int:
    net = common.network(args)
    t = common.resolve_node(net, args.node)
    info = common.lookup(t, args.name)
    if not info.writable:
        raise UserError(f"{info.key} is {'read-only' if info.access in ('ro', 'const') else info.access}; not sent")
    value = common.parse_value(info, args.value)
    common.check_range(info, value)
    with common.canopen_network(args, net) as nw:
        node = common.remote(nw, t, args.timeout)
        common.sdo_write(node, t, info, value)
        back = common.sdo_read(node, t, info) if "r" in info.access else value
    print(f"{t.role}: {info.key} = {common.fmt(back, info)}    ({describe(info)})")
    return 0
