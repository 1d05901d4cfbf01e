"""``telethermo save`` and ``telethermo restore-defaults``: CiA 301 store parameters (0x1010) and restore
default parameters (0x1011) of a node.

``save NODE`` writes the signature "save" (0x65766173) to 0x1010 sub 1 (all parameters; ``--group``
communication: sub 2, application: sub 3): the node writes its store file (gains, limits, the loaded model,
rendering and identification settings, communication settings) before it answers, and restores it at every
start. ``restore-defaults NODE`` writes "load" (0x64616F6C) to 0x1011: the defaults come back at the node's
next reset (``telethermo nmt reset NODE``) or start, as CiA 301 says. The node's answer is read back from
0x2720..0x2722 (what is in force, and the file).
"""

from __future__ import annotations

import argparse

from telethermo.cli import common
from telethermo.remote import values
from telethermo.remote.client import NodeClient
from telethermo.remote.errors import Failure, Refused, UserError, abort_text
from telethermo.remote.targets import Target, lookup, resolve_node

SAVE_SIGNATURE, LOAD_SIGNATURE = 0x65766173, 0x64616F6C  # "save", "load" (telethermo.device.storage)
GROUP_SUBS = {"all": 1, "communication": 2, "application": 3}


def register(subparsers) -> None:
    for name, what in (
        ("save", "store the node's parameters in its store file (0x1010), restored at each start"),
        ("restore-defaults", "the node's default parameters at its next reset or start (0x1011)"),
    ):
        p = subparsers.add_parser(
            name, description=f"CiA 301: {what}. Exit 1 if a node refuses or does not answer."
        )
        common.add_bus_options(p)
        p.add_argument("nodes", nargs="+", metavar="NODE", help="master, slave or a node-ID")
        p.add_argument(
            "--group",
            choices=list(GROUP_SUBS),
            default="all",
            help="all parameters (sub 1, default), communication (sub 2) or application (sub 3)",
        )
        p.set_defaults(func=run, store_command=name)


def _report(node: NodeClient, t: Target) -> str:
    """What the node says is in force now (its store objects), or '' if its EDS has none."""
    try:
        state_info, file_info = lookup(t, "store_state"), lookup(t, "store_file")
    except UserError:
        return ""
    state = node.read(state_info)
    return f"; store {values.fmt(state, state_info, node.eds)}, file {node.read(file_info)}"


@common.failures
def run(args: argparse.Namespace) -> int:
    net = common.network(args)
    targets = [resolve_node(net, n) for n in args.nodes]
    saving = args.store_command == "save"
    index, signature = (0x1010, SAVE_SIGNATURE) if saving else (0x1011, LOAD_SIGNATURE)
    sub = GROUP_SUBS[args.group]
    infos = [lookup(t, f"0x{index:04X}sub{sub}") for t in targets]  # a node without the object: exit 2 first
    with common.canopen_network(args, net) as nw:
        for t, info in zip(targets, infos):
            node = NodeClient(nw, t, args.timeout)
            try:
                node.write(info, signature)
            except Refused as exc:
                raise Failure(
                    f"{t.role} (node {t.node_id}) refused to {'save' if saving else 'restore'} "
                    f"{args.group} parameters: {abort_text(exc.code)}"
                ) from None
            what = (
                f"{args.group} parameters saved"
                if saving
                else f"{args.group} default parameters restored: in force after its next reset "
                f"(telethermo nmt reset {t.role}) or start"
            )
            print(f"{t.role} (node {t.node_id}): {what}{_report(node, t)}")
    return 0
