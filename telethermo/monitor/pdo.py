"""PDO mapping table of the bus: from each node's EDS, updated by the remapping seen on the bus.

Each node's TPDOs (0x1800+n communication, 0x1A00+n mapping) say which COB-ID it sends and what the
bytes mean; its RPDOs (0x1400+n, 0x1600+n) say what it expects. A frame is decoded by its
producer's TPDO when one is known, else by a consumer's RPDO. SDO writes (and reads) of those
objects observed on the bus update the table, so a runtime remapping (CiA 301 §7.5.2.36: disable
the PDO, set sub0 = 0, write the entries, set sub0 = N, enable) is followed; NMT reset node /
reset communication restores the EDS values.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from typing import Any

from canopen import objectdictionary as od_mod

from telethermo.control.render_table import material_name

from .material import ABSTAIN_CODE

TPDO_COMM, TPDO_MAP, RPDO_COMM, RPDO_MAP = 0x1800, 0x1A00, 0x1400, 0x1600

#: our objects whose value is a material code of the rendering table (the master's rendered material, the
#: slave's identified one and the master's copy of it): (index, EDS name), so that another vendor's 0x26xx
#: is left alone
MATERIAL_CODE_OBJECTS = frozenset(
    {
        (0x2600, "material_code"),
        (0x2610, "identified_material"),
        (0x2615, "peer_identified_material"),
        (0x261C, "identified_early_material"),
        (0x261F, "peer_identified_early_material"),
    }
)


@dataclass(frozen=True, slots=True)
class MappedEntry:
    """One mapped object: index, sub-index, length in bits, and what the OD says about it."""

    index: int
    subindex: int
    bits: int
    name: str
    unit: str = ""
    var: Any = None  # canopen ODVariable or None (unknown / dummy mapping)


@dataclass(frozen=True, slots=True)
class PdoDef:
    """A PDO as currently configured: who sends it, its COB-ID, validity and mapping."""

    node: int
    direction: str  # "TPDO" (node transmits) or "RPDO" (node receives)
    number: int  # 1..512
    cob_id: int
    valid: bool
    transmission_type: int | None
    entries: tuple[MappedEntry, ...]

    @property
    def label(self) -> str:
        return f"{self.direction}{self.number}"

    @property
    def length_bits(self) -> int:
        return sum(e.bits for e in self.entries)


@dataclass(slots=True)
class PdoValue:
    name: str
    value: Any
    unit: str
    index: int
    subindex: int

    def to_json(self) -> dict[str, Any]:
        v = self.value
        if isinstance(v, (bytes, bytearray)):
            v = bytes(v).hex()
        elif isinstance(v, float) and v != v:
            v = "NaN"
        elif isinstance(v, float) and v in (float("inf"), float("-inf")):
            v = str(v)
        out = {
            "name": self.name,
            "value": v,
            "unit": self.unit,
            "index": self.index,
            "subindex": self.subindex,
        }
        meaning = self.meaning()
        if meaning:
            out["meaning"] = meaning
        return out

    def meaning(self) -> str:
        """What the value stands for, where the object is an enumeration the monitor knows (a material code's
        name in the rendering table); '' otherwise."""
        if (self.index, self.name) in MATERIAL_CODE_OBJECTS and isinstance(self.value, int):
            return "unknown" if self.value == ABSTAIN_CODE else material_name(self.value)
        return ""

    def text(self) -> str:
        """``name=value unit`` for a person, with the value's meaning in parentheses where known."""
        meaning = self.meaning()
        return f"{self.name}={format_value(self.value, self.unit)}" + (f" ({meaning})" if meaning else "")


def od_var(od, index: int, sub: int):
    try:
        obj = od[index]
    except KeyError:
        return None
    if isinstance(obj, od_mod.ODVariable):
        return obj if sub == 0 else None
    try:
        return obj[sub]
    except KeyError:
        return None


def od_value(od, index: int, sub: int) -> int | None:
    var = od_var(od, index, sub)
    if var is None:
        return None
    v = var.value if var.value is not None else var.default
    return v if isinstance(v, int) else None


@dataclass
class PdoMap:
    """PDO configuration of every known node (node-ID -> canopen ObjectDictionary)."""

    ods: dict[int, Any]
    _values: dict[int, dict[tuple[int, int], int]] = field(default_factory=dict)
    _cache: dict[int, PdoDef] | None = None

    def __post_init__(self) -> None:
        for node in self.ods:
            self.reset_node(node)

    # -- configuration ---------------------------------------------------------------------------
    def reset_node(self, node: int) -> None:
        """Back to the EDS values (NMT reset node / reset communication)."""
        od = self.ods.get(node)
        vals: dict[tuple[int, int], int] = {}
        if od is not None:
            for base in (TPDO_COMM, TPDO_MAP, RPDO_COMM, RPDO_MAP):
                for n in range(512):
                    index = base + n
                    if index not in od:
                        continue
                    obj = od[index]
                    for sub in range(0, 9) if base in (TPDO_COMM, RPDO_COMM) else range(0, 65):
                        v = od_value(od, index, sub) if not isinstance(obj, od_mod.ODVariable) else None
                        if v is not None:
                            vals[(index, sub)] = v
        self._values[node] = vals
        self._cache = None

    def observe_sdo(self, node: int, index: int, sub: int, data: bytes) -> str | None:
        """Take note of a successful SDO transfer (either direction); a text if it changed a PDO."""
        if not RPDO_COMM <= index < TPDO_MAP + 0x200 or not data or len(data) > 4:
            return None
        value = int.from_bytes(bytes(data), "little")
        vals = self._values.setdefault(node, {})
        if vals.get((index, sub)) == value:
            return None
        vals[(index, sub)] = value
        self._cache = None
        kind = {
            RPDO_COMM: "RPDO comm",
            RPDO_MAP: "RPDO mapping",
            TPDO_COMM: "TPDO comm",
            TPDO_MAP: "TPDO mapping",
        }[index & 0xFE00]
        return f"node {node} {kind} {(index & 0x1FF) + 1} sub {sub} := 0x{value:X}"

    # -- lookup ----------------------------------------------------------------------------------
    def _build(self) -> dict[int, PdoDef]:
        table: dict[int, PdoDef] = {}
        rpdos: dict[int, PdoDef] = {}
        for node, vals in self._values.items():
            od = self.ods.get(node)
            for direction, comm, mapping, target in (
                ("TPDO", TPDO_COMM, TPDO_MAP, table),
                ("RPDO", RPDO_COMM, RPDO_MAP, rpdos),
            ):
                for n in range(512):
                    raw = vals.get((comm + n, 1))
                    if raw is None:
                        continue
                    valid = not raw & 0x80000000
                    cob = raw & (0x1FFFFFFF if raw & 0x20000000 else 0x7FF)
                    count = vals.get((mapping + n, 0), 0)
                    entries = []
                    for i in range(1, min(count, 64) + 1):
                        m = vals.get((mapping + n, i), 0)
                        index, sub, bits = m >> 16, (m >> 8) & 0xFF, m & 0xFF
                        var = od_var(od, index, sub) if od is not None else None
                        if var is None:
                            name = f"dummy{bits}" if index < 0x20 else f"0x{index:04X}:{sub:02X}"
                        else:
                            name = var.name
                        entries.append(
                            MappedEntry(index, sub, bits, name, getattr(var, "unit", "") or "", var)
                        )
                    pdef = PdoDef(node, direction, n + 1, cob, valid, vals.get((comm + n, 2)), tuple(entries))
                    if valid and (cob not in target or not target[cob].valid):
                        target[cob] = pdef
        for cob, pdef in rpdos.items():
            table.setdefault(cob, pdef)  # a producer's TPDO wins over a consumer's RPDO
        return table

    @property
    def table(self) -> dict[int, PdoDef]:
        if self._cache is None:
            self._cache = self._build()
        return self._cache

    def cob_ids(self) -> set[int]:
        return set(self.table)

    def lookup(self, cob_id: int) -> PdoDef | None:
        return self.table.get(cob_id)


def decode_pdo(pdef: PdoDef, data: bytes) -> tuple[list[PdoValue], str | None]:
    """Named values of a PDO frame by its mapping; and an error text for a length mismatch."""
    data = bytes(data)
    need = pdef.length_bits
    err = None
    if len(data) * 8 < need:
        err = f"{pdef.label} of node {pdef.node}: {len(data)} bytes, mapping needs {(need + 7) // 8}"
    raw = int.from_bytes(data, "little")
    out: list[PdoValue] = []
    offset = 0
    for e in pdef.entries:
        if offset + e.bits > len(data) * 8:
            break
        piece = (raw >> offset) & ((1 << e.bits) - 1)
        offset += e.bits
        if e.var is None:
            if e.index < 0x20:
                continue  # dummy mapping: skipped bits
            value: Any = piece
        else:
            nbytes = (e.bits + 7) // 8
            blob = piece.to_bytes(nbytes, "little")
            try:
                if e.var.data_type == od_mod.BOOLEAN:
                    value = bool(piece)
                elif e.var.fixed_size and len(e.var) != e.bits:
                    value = piece
                else:
                    value = e.var.decode_raw(blob)
            except (od_mod.ObjectDictionaryError, struct.error, ValueError):
                value = blob
        out.append(PdoValue(e.name, value, e.unit, e.index, e.subindex))
    return out, err


def format_value(value: Any, unit: str = "") -> str:
    """A value for a person: floats to 4 significant decimals, bytes as hex, unit appended."""
    if isinstance(value, float):
        text = f"{value:.4g}" if abs(value) >= 1e4 or (value != 0 and abs(value) < 1e-3) else f"{value:.3f}"
    elif isinstance(value, (bytes, bytearray)):
        text = bytes(value).hex()
    else:
        text = str(value)
    return f"{text} {unit}".rstrip() if unit else text
