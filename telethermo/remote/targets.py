"""The nodes as the operator names them: ``master``, ``slave``, a node-ID, from the network file, each with
its EDS (parsed once per file version) and its objects by name."""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

from telethermo.device.eds_info import EdsError, EdsInfo, VarInfo
from telethermo.device.netconfig import NetworkConfig
from telethermo.remote.errors import UserError


@dataclass(frozen=True)
class Target:
    """A node as the operator names it (``eds`` None: a node-ID outside the network file,
    e.g. for ``sdo``)."""

    role: str
    node_id: int
    eds: Path | None


def node_targets(net: NetworkConfig) -> list[Target]:
    """Every node of the network file, by node-ID."""
    return sorted(
        (
            Target(role, n.node_id, Path(n.eds) if n.eds is not None else None)
            for role, n in net.nodes.items()
        ),
        key=lambda t: t.node_id,
    )


PAIR_ROLES = ("master", "slave")


def pair_targets(net: NetworkConfig) -> list[Target]:
    """Our two nodes, by their role in the network file ([nodes.master], [nodes.slave]): what ``mode`` and
    ``fault-reset`` address; other devices of the file (an arm, I/O modules) never get our objects."""
    return [t for t in node_targets(net) if t.role in PAIR_ROLES]


def resolve_node(net: NetworkConfig, text: str) -> Target:
    """``master`` / ``slave`` / a node-ID -> Target; UserError listing the known nodes otherwise."""
    known = node_targets(net)
    for t in known:
        if (
            text.lower() == t.role
            or text == str(t.node_id)
            or (text.lower().startswith("0x") and _int(text) == t.node_id)
        ):
            return t
    names = ", ".join(f"{t.role} ({t.node_id})" for t in known)
    raise UserError(f"unknown node {text!r}; expected one of {names} (from {net.path})")


def resolve_any_node(net: NetworkConfig, text: str) -> Target:
    """Like :func:`resolve_node`, and also any node-ID 1..127 outside the network file (no EDS:
    raw SDO, NMT)."""
    try:
        return resolve_node(net, text)
    except UserError:
        node_id = _int(text)
        if node_id is None or not 1 <= node_id <= 127:
            names = ", ".join(t.role for t in node_targets(net))
            raise UserError(f"node {text!r}: expected a node-ID 1..127 or one of {names}") from None
        return Target(f"node {node_id}", node_id, None)


def _int(text: str) -> int | None:
    try:
        return int(text, 0)
    except ValueError:
        return None


@functools.lru_cache(maxsize=16)
def _parsed_eds(path: str, mtime_ns: int) -> EdsInfo:
    return EdsInfo(path)


def eds_info(target: Target) -> EdsInfo:
    """The node's EDS, parsed once per file version (a parse takes ~20 ms; a command may look up hundreds
    of names, e.g. identify's SDO set-up and model load)."""
    if target.eds is None:
        raise UserError(
            f"{target.role} (node {target.node_id}) has no EDS (give one in the network file, "
            f"[nodes.{target.role}] eds = ...), so its objects have no names: use "
            f"telethermo sdo {target.node_id} INDEX:SUB"
        )
    try:
        try:
            mtime = Path(target.eds).stat().st_mtime_ns
        except OSError:
            return EdsInfo(target.eds)  # names the file and what is wrong with it
        return _parsed_eds(str(target.eds), mtime)
    except EdsError as exc:
        raise UserError(str(exc)) from None


def lookup(target: Target, name: str | int | tuple[int, int]) -> VarInfo:
    """A variable of the node's EDS by name or number; UserError with suggestions if unknown."""
    try:
        return eds_info(target).get(name)
    except KeyError as exc:
        raise UserError(exc.args[0]) from None
