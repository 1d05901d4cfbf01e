"""``telethermo apply-gains FILE [NODE...]``: a tuned gains file (``tune --out``) into running nodes.

The rule is the file's own: its ``"apply"`` entry (:func:`telethermo.control.gainsfile.apply_marks`) marks
the gains a running node takes by SDO (``sdo``: kp_A_per_C, ki_A_per_C_s, kQ_A_per_W, objects
0x2200..0x2202) and those that have no object and need a node start with ``--gains FILE`` (``restart``:
the flux loop's kpQ_A_per_W, kiQ_A_per_W_s). A file without the entry (written before it existed) gets the
same rule. The file holds telepresence gains and a node keeps its gains per mode, writing into the mode it
is in: a node in another mode is refused (nothing written to any node), as is a marked key whose object the
node's EDS lacks or a value outside its EDS range. Each write is read back and printed as ``set`` prints it;
one line then names the keys that need the restart.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from telethermo.cli import common
from telethermo.cli.params import line  # the line `set` prints
from telethermo.control.gainsfile import GAIN_FIELDS, GAINS_FILE, apply_marks, read_gains
from telethermo.control.types import Mode, Role
from telethermo.inputfile import InputFileError, Section, load_json
from telethermo.remote.client import NodeClient
from telethermo.remote.errors import Failure, Refused, UserError
from telethermo.remote.targets import PAIR_ROLES, Target, eds_info, lookup, pair_targets, resolve_node
from telethermo.remote.values import check_range


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "apply-gains", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    common.add_bus_options(p)
    p.add_argument("file", type=Path, metavar="FILE", help="gains file written by `telethermo tune --out`")
    p.add_argument(
        "nodes",
        nargs="*",
        metavar="NODE",
        help="master, slave or a node-ID (default: the master and the slave of the network file)",
    )
    p.set_defaults(func=run)


def marks(doc: Section) -> tuple[list[str], list[str]]:
    """The file's (sdo keys, restart keys); InputFileError naming the file and the field of a wrong entry."""
    whole = 'an object with "mode": "telepresence", "sdo" and "restart"'
    mark = doc.table("apply", default=apply_marks(), expected=whole)
    mark.str("mode", choices=("telepresence",))
    expected = f"a list of gain names from {', '.join(GAIN_FIELDS)}"
    lists = []
    for field in ("sdo", "restart"):
        keys = mark.list(field, expected=expected)
        if any(k not in GAIN_FIELDS for k in keys):
            raise mark.fail(field, expected, keys)
        lists.append(keys)
    if set(lists[0]) & set(lists[1]) or set(lists[0]) | set(lists[1]) != set(GAIN_FIELDS):
        raise doc.error.whole(
            doc.file, f"apply: sdo and restart must split the gains {', '.join(GAIN_FIELDS)} between them"
        )
    return lists[0], lists[1]


def _targets(args: argparse.Namespace, net) -> list[Target]:
    targets = [resolve_node(net, n) for n in args.nodes] if args.nodes else pair_targets(net)
    for t in targets:
        if t.role not in PAIR_ROLES:
            raise UserError(
                f"{t.role} (node {t.node_id}): a gains file holds gains of the master and the slave only"
            )
    return targets


@common.failures
def run(args: argparse.Namespace) -> int:
    net = common.network(args)
    try:
        doc = load_json(args.file, GAINS_FILE)
        gains = read_gains(doc)  # validated: format, names, numbers, CoreParams ranges
        sdo_keys, restart_keys = marks(doc)
    except InputFileError as exc:
        raise UserError(str(exc)) from None
    targets = _targets(args, net)
    plan = []
    for t in targets:
        values = gains[Role(t.role)]
        for key in sdo_keys:
            if key not in values:
                continue
            try:
                info = lookup(t, key)
            except UserError:
                raise UserError(
                    f"{args.file}: apply.sdo marks {key}, but {eds_info(t).path} has no object "
                    f"{key}; not sent"
                ) from None
            try:
                check_range(info, values[key])
            except UserError as exc:
                raise UserError(f"{args.file}: {t.role}.{key}: {exc}") from None  # exc says "not sent"
            plan.append((t, info, values[key]))

    with common.canopen_network(args, net) as nw:
        clients = {t.role: NodeClient(nw, t, args.timeout) for t in targets}
        for t in targets:  # every node in telepresence before any write
            mode = clients[t.role].read(lookup(t, "mode"))
            if int(mode) != int(Mode.TELEPRESENCE):
                name = Mode(mode).name.lower() if int(mode) in Mode._value2member_map_ else str(mode)
                raise Failure(
                    f"{t.role} is in {name}: the file holds telepresence gains and a node writes "
                    f"a gain into the mode it is in; nothing written (`telethermo mode "
                    f"telepresence` first, or start the nodes with --gains {args.file})"
                )
        for t, info, value in plan:
            node = clients[t.role]
            try:
                node.write(info, value)
            except Refused as exc:
                raise Failure(f"{exc} (from {args.file})") from None
            print(line(t, info, node.read(info), node.eds))
    pending = [
        f"{t.role} {k} = {gains[Role(t.role)][k]:g}"
        for t in targets
        for k in restart_keys
        if k in gains[Role(t.role)]
    ]
    if pending:
        print(f"needs a node start with --gains {args.file} (no object to write): {', '.join(pending)}")
    return 0
