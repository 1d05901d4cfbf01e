"""Which frames to keep (``telethermo record --filter``, ``telethermo replay --filter``).

Each filter is python-can's ``can_filters`` convention (as ``python -m can.logger --filter``):
``ID:MASK`` keeps a frame whose ``COB-ID & MASK == ID & MASK``, ``ID~MASK`` one whose ``COB-ID & MASK !=
ID & MASK`` (hexadecimal, e.g. ``180:780`` every TPDO1), or a name the network file and the EDS give:
a node (``master``: every frame whose COB-ID carries its node-ID, COB-ID & 0x7F), a CANopen service
(``nmt``, ``sync``, ``emcy``, ``heartbeat``, ``sdo``, ``pdo``), a PDO (``master.TPDO4``) or an object
mapped into PDOs (``cycle_counter``: the PDOs that carry it). A frame is kept if any filter matches.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

import can

from .pdo import PdoMap
from .records import MonitorConfig

#: CANopen services by their COB-ID ranges (CiA 301 predefined connection set)
SERVICES: dict[str, tuple[range, ...]] = {
    "nmt": (range(0x000, 0x001),),
    "sync": (range(0x080, 0x081),),
    "emcy": (range(0x081, 0x100),),
    "heartbeat": (range(0x701, 0x780),),
    "sdo": (range(0x581, 0x600), range(0x601, 0x680)),
}


class FilterError(ValueError):
    """A filter that is neither ID:MASK, ID~MASK nor a known name (the message says which are)."""


@dataclass(frozen=True)
class Match:
    """One filter: a COB-ID set (names) or a python-can id/mask pair, maybe inverted."""

    text: str
    can_id: int = 0
    mask: int = 0
    invert: bool = False
    ids: frozenset[int] | None = None
    node: int | None = None

    def __call__(self, msg: can.Message) -> bool:
        cob = msg.arbitration_id
        if self.ids is not None:
            return not msg.is_extended_id and cob in self.ids
        if self.node is not None:
            return not msg.is_extended_id and cob != 0 and cob & 0x7F == self.node
        hit = cob & self.mask == self.can_id & self.mask
        return hit != self.invert


def _hex(text: str, spec: str) -> int:
    try:
        return int(text, 16)
    except ValueError:
        raise FilterError(
            f"--filter {spec!r}: {text!r} is not hexadecimal; expected ID:MASK or ID~MASK "
            "as python-can's --filter, e.g. 180:780"
        ) from None


def parse_filter(spec: str, config: MonitorConfig | None = None) -> Match:
    """One filter from its text (see the module docstring); FilterError naming it otherwise."""
    for sep, invert in ((":", False), ("~", True)):
        if sep in spec:
            can_id, _, mask = spec.partition(sep)
            return Match(spec, _hex(can_id, spec), _hex(mask, spec), invert)
    name = spec.strip().lower()
    if name in SERVICES:
        return Match(spec, ids=frozenset(c for r in SERVICES[name] for c in r))
    config = config or MonitorConfig()
    nodes = {info.name.lower(): nid for nid, info in config.nodes.items()}
    if name in nodes:
        return Match(spec, node=nodes[name])
    pmap = PdoMap(ods={k: n.od for k, n in config.nodes.items() if n.od is not None})
    tpdos = [p for p in pmap.table.values() if p.direction == "TPDO"]
    if name == "pdo":
        return Match(spec, ids=frozenset(p.cob_id for p in pmap.table.values()))
    named = {f"{config.nodes[p.node].name}.{p.label}": p.cob_id for p in tpdos}
    lowered = {k.lower(): v for k, v in named.items()}
    if name in lowered:
        return Match(spec, ids=frozenset({lowered[name]}))
    carrying = frozenset(p.cob_id for p in tpdos if any(e.name.lower() == name for e in p.entries))
    if carrying:
        return Match(spec, ids=carrying)
    known = sorted(SERVICES) + ["pdo"] + sorted(info.name for info in config.nodes.values()) + sorted(named)
    raise FilterError(
        f"--filter {spec!r}: not ID:MASK, ID~MASK (hexadecimal, python-can's convention) nor a "
        f"name; expected one of {', '.join(known)}, or an object mapped into a TPDO"
    )


def frame_filter(specs: Iterable[str], config: MonitorConfig | None = None):
    """A predicate keeping a frame that any of ``specs`` matches (no specs: every frame)."""
    matches = [parse_filter(s, config) for s in specs]
    if not matches:
        return lambda msg: True
    return lambda msg: any(m(msg) for m in matches)
