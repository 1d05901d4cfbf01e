"""``telethermo mode``: telepresence | render <material> | idle.

Only our two nodes are addressed, by their role in the network file (``[nodes.master]``,
``[nodes.slave]``); other devices of the file never get a ``mode`` write. ``render`` sets the master to
render alone and the slave to idle (its current to zero: nothing couples it to the master while the master
renders), and says so; ``telepresence`` couples both again. A material of the shipped rendering table is
written as its code (0x2600 ``material_code``, its position in the table), so ``get master material_code``
names it; a custom ``--beta`` or a material of another ``--table`` is code 0 (custom) with its β.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from telethermo.cli import common
from telethermo.cli.main import UserError
from telethermo.control.rendering import DEFAULT_RENDER_TABLE, load_render_table
from telethermo.control.types import Mode
from telethermo.remote.client import NodeClient
from telethermo.remote.errors import Failure
from telethermo.remote.targets import Target, lookup, pair_targets, resolve_node
from telethermo.remote.values import check_range


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "mode",
        description="telepresence: both nodes couple bilaterally (guiatni eq. 34/35). "
        "render MATERIAL: the master renders a virtual material alone "
        "(yamamoto eq. 7; β from the rendering table, or --beta). idle: "
        "current to zero through the safety envelope's ramp.",
    )
    common.add_bus_options(p)
    p.add_argument("mode", choices=["telepresence", "render", "idle"])
    p.add_argument(
        "material", nargs="?", help="render only: a material of the rendering table (e.g. wood, brass)"
    )
    p.add_argument("--beta", type=float, help="render: relative effusivity β of a custom material instead")
    p.add_argument("--object-temp", type=float, metavar="C", help="render: object's initial temperature, °C")
    p.add_argument(
        "--table", metavar="TOML", help="rendering table (default: telethermo/data/render_materials.toml)"
    )
    p.set_defaults(func=run)


def _material(args) -> tuple[str, float, int]:
    """(name, β, material_code): the code is the material's 1-based position in the shipped rendering table
    (the nodes' table), 0 for --beta or a material of another --table."""
    if args.beta is not None:
        if args.material:
            raise UserError("give a MATERIAL or --beta, not both")
        return "custom", args.beta, 0
    if not args.material:
        raise UserError("render needs a MATERIAL (or --beta)")
    try:
        table = load_render_table(args.table)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    key = args.material.lower()
    if key not in table:
        raise UserError(
            f"unknown material {args.material!r}; the rendering table has {', '.join(sorted(table))}"
        )
    code = (
        1 + list(table).index(key)
        if args.table is None or Path(args.table).resolve() == DEFAULT_RENDER_TABLE
        else 0
    )
    return key, table[key], code


@common.failures
def run(args: argparse.Namespace) -> int:
    net = common.network(args)
    if args.mode != "render" and (args.material or args.beta is not None or args.object_temp is not None):
        raise UserError(f"{args.mode} takes no material, --beta or --object-temp")
    writes: list[tuple[Target, str, object]] = []
    optional: set[int] = set()  # node-IDs whose silence is reported, not a failure (render: the slave)
    if args.mode == "render":
        name, beta, code = _material(args)
        master = resolve_node(net, "master")
        slave = next((t for t in pair_targets(net) if t.role == "slave"), None)
        if slave is not None:  # first: nothing drives the operator's pad while the slave still follows it
            writes.append((slave, "mode", int(Mode.IDLE)))
            optional.add(slave.node_id)
        # β first, the code last: a node sets β from its table when the code is written, and the code to 0
        # (custom) when β is
        for key, value in (("material_beta", beta), ("material_code", code)) + (
            (("object_T0_C", args.object_temp),) if args.object_temp is not None else ()
        ):
            writes.append((master, key, value))
        writes.append((master, "mode", int(Mode.RENDER)))
        desc = f"render {name} (β = {beta:g}, material_code {code}{' custom' if code == 0 else ''})"
    else:
        mode = Mode.TELEPRESENCE if args.mode == "telepresence" else Mode.IDLE
        # the slave first: the master starts driving the operator's pad last
        for t in sorted(pair_targets(net), key=lambda t: t.role != "slave"):
            writes.append((t, "mode", int(mode)))
        desc = args.mode
    # check every value locally before sending anything
    planned = []
    for t, key, value in writes:
        info = lookup(t, key)
        check_range(info, value)
        planned.append((t, info, value))
    with common.canopen_network(args, net) as nw:
        nodes = {}
        absent = set()
        for t, info, value in planned:
            if t.node_id not in nodes:
                nodes[t.node_id] = NodeClient(nw, t, args.timeout)
            try:
                nodes[t.node_id].write(info, value)
            except Failure as exc:
                if t.node_id not in optional or "did not answer" not in str(exc):
                    raise
                absent.add(t.node_id)
                print(
                    f"{t.role} (node {t.node_id}): not answering, so not set to idle "
                    "(the master renders alone)"
                )
        wanted = {
            t.node_id: (t, v) for t, info, v in planned if info.key == "mode" and t.node_id not in absent
        }
        refused = []
        for t, v in wanted.values():
            # the node applies the mode in its own thread and writes the object back if it refuses:
            # poll the read-back for a few control cycles before believing either way
            deadline = time.monotonic() + 0.5
            while True:
                back = nodes[t.node_id].read(lookup(t, "mode"))
                if back == v or time.monotonic() >= deadline:
                    break
                time.sleep(0.05)
            name = Mode(back).name.lower() if back in Mode._value2member_map_ else str(back)
            why = (
                " (while the master renders alone; `telethermo mode telepresence` couples both again)"
                if args.mode == "render" and t.role == "slave" and back == v
                else ""
            )
            print(f"{t.role} (node {t.node_id}): mode {name}{why}")
            if back != v:
                refused.append(f"{t.role} stays in {name}")
    if refused:
        raise Failure(f"mode {desc} not taken: {'; '.join(refused)} (the node refused it; see its log)")
    print(f"mode: {desc}")
    return 0
