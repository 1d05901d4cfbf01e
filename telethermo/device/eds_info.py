"""What an EDS says about each object that canopen's parser drops or hides: limits, units, names.

canopen 2.4 parses ``LowLimit``/``HighLimit`` with ``int(text, 0)`` only, so REAL32 limits written as
decimals are silently lost. This module re-reads the EDS text and gives, for every variable, its
name, data type, access, unit, default and limits (floats for REAL32), and resolves the names the
operator CLI accepts:

- a top-level variable's name: ``kp_A_per_C``, ``Producer heartbeat time``
- ``<object>.<entry>`` for an entry of an ARRAY/RECORD: ``Identity object.Vendor-ID``
- an entry name alone when it is unique in the dictionary: ``theta3``
- numbers: ``0x2200``, ``0x1018sub1``, ``0x1018:1``, ``0x1018.1``
"""

from __future__ import annotations

import math
import re
from configparser import RawConfigParser
from dataclasses import dataclass, replace
from pathlib import Path

from telethermo.cia301 import ABORT_RANGE, ABORT_TOO_HIGH, ABORT_TOO_LOW

REAL_TYPES = {0x0008, 0x0011}  # REAL32, REAL64
SIGNED_BITS = {0x0002: 8, 0x0003: 16, 0x0004: 32, 0x0015: 64}
UNSIGNED_TYPES = {0x0001, 0x0005, 0x0006, 0x0007, 0x001B}
TYPE_NAMES = {
    0x0001: "BOOLEAN",
    0x0002: "INTEGER8",
    0x0003: "INTEGER16",
    0x0004: "INTEGER32",
    0x0005: "UNSIGNED8",
    0x0006: "UNSIGNED16",
    0x0007: "UNSIGNED32",
    0x0008: "REAL32",
    0x0009: "VISIBLE_STRING",
    0x000A: "OCTET_STRING",
    0x0011: "REAL64",
    0x0015: "INTEGER64",
    0x001B: "UNSIGNED64",
}


class EdsError(ValueError):
    """An EDS file is unreadable or inconsistent (message names the file, section and key)."""


@dataclass(frozen=True, slots=True)
class VarInfo:
    """One variable of the dictionary as the EDS describes it.

    Attributes:
        index, subindex: where it lives (subindex 0 for a VAR object).
        name: its ParameterName; ``key`` is the name the CLI uses (``name`` or ``parent.name``).
        data_type: CiA 301 data type code (0x0008 REAL32, ...); ``type_name`` its name.
        access: ro, wo, rw, rwr, rww or const.
        unit: ASCII unit from the ``Unit=`` key ("" if dimensionless).
        low, high: limits (float for REAL types, int otherwise) or None.
        default: DefaultValue as written in the EDS (text).
        pdo_mappable: PDOMapping=1.
        description: free text ("" if none).
    """

    index: int
    subindex: int
    name: str
    key: str
    data_type: int
    access: str
    unit: str
    low: float | int | None
    high: float | int | None
    default: str
    pdo_mappable: bool
    description: str

    @property
    def type_name(self) -> str:
        return TYPE_NAMES.get(self.data_type, f"0x{self.data_type:04X}")

    @property
    def writable(self) -> bool:
        return "w" in self.access

    def range_text(self) -> str:
        """Human-readable range with unit, e.g. ``[0.0, 20.0] A/degC`` ('' if unlimited)."""
        if self.low is None and self.high is None:
            return ""
        lo = "-inf" if self.low is None else f"{self.low:g}" if isinstance(self.low, float) else str(self.low)
        hi = (
            "+inf"
            if self.high is None
            else f"{self.high:g}"
            if isinstance(self.high, float)
            else str(self.high)
        )
        return f"[{lo}, {hi}]" + (f" {self.unit}" if self.unit else "")


def _number(text: str, data_type: int, where: str) -> float | int:
    text = text.strip()
    try:
        if data_type in REAL_TYPES:
            return float(text)
        if "$NODEID" in text.upper():
            raise EdsError(f"{where}: a limit cannot depend on $NODEID, got {text!r}")
        value = int(text, 0)
        bits = SIGNED_BITS.get(data_type)
        if bits and value >= 1 << (bits - 1):  # limits of signed types may be written as hex two's complement
            value -= 1 << bits
        return value
    except ValueError:
        raise EdsError(
            f"{where}: expected a number for a {TYPE_NAMES.get(data_type, hex(data_type))}, got {text!r}"
        ) from None


#: how the API names an object: its name or CLI key, ``"0x1018sub1"``, an index, or (index, subindex)
ObjectKey = str | int | tuple[int, int]

OBJECT_LISTS = ("MandatoryObjects", "OptionalObjects", "ManufacturerObjects")


def _check_object_lists(parser: RawConfigParser, path: Path) -> None:
    """CiA 306: an EDS lists its objects in [MandatoryObjects]/[OptionalObjects]/[ManufacturerObjects]
    (SupportedObjects = N, then 1..N = index) and describes each in its own section. An empty file, a file
    without the lists, or a truncated one (listed objects without their section) is refused here, naming
    what is missing, instead of giving a partial dictionary."""
    if not parser.has_section("MandatoryObjects"):
        what = "an empty file" if not parser.sections() else "no [MandatoryObjects] section"
        raise EdsError(f"{path}: not an EDS file ({what}; CiA 306 lists the objects in [MandatoryObjects])")
    missing = []
    for lst in OBJECT_LISTS:
        if not parser.has_section(lst):
            continue
        try:
            n = int(parser.get(lst, "SupportedObjects", fallback="0"), 0)
            listed = [int(parser.get(lst, str(k)), 0) for k in range(1, n + 1)]
        except (ValueError, TypeError) as exc:
            raise EdsError(
                f"{path}: [{lst}]: expected SupportedObjects = N and entries 1..N = index "
                f"({' '.join(str(exc).split())})"
            ) from None
        missing += [f"0x{i:04X}" for i in listed if not parser.has_section(f"{i:04X}")]
    if missing:
        shown = ", ".join(missing[:5]) + (f" and {len(missing) - 5} more" if len(missing) > 5 else "")
        raise EdsError(
            f"{path}: {len(missing)} listed object(s) have no section ({shown}): truncated or damaged EDS"
        )


class EdsInfo:
    """All variables of one EDS file, by (index, subindex) and by CLI key."""

    def __init__(self, source: str | Path):
        self.path = Path(source)
        parser = RawConfigParser(inline_comment_prefixes=(";",), strict=False)
        # keep names' case: configparser's documented idiom, which typeshed types as assigning to a method
        parser.optionxform = str  # type: ignore[assignment,method-assign]
        try:
            with open(self.path, encoding="ascii") as fh:
                parser.read_file(fh)
        except (OSError, UnicodeDecodeError) as exc:
            raise EdsError(f"{self.path}: cannot read EDS ({exc})") from exc
        except Exception as exc:  # configparser errors: one line, however many the parser wrote
            raise EdsError(f"{self.path}: not an INI/EDS file ({' '.join(str(exc).split())})") from exc
        _check_object_lists(parser, self.path)
        self.vars: dict[tuple[int, int], VarInfo] = {}
        self.by_key: dict[str, VarInfo] = {}
        self.object_names: dict[int, str] = {}
        sub_name_count: dict[str, int] = {}
        for section in parser.sections():
            m_obj = re.fullmatch(r"([0-9A-Fa-f]{4})", section)
            m_sub = re.fullmatch(r"([0-9A-Fa-f]{4})[Ss]ub([0-9A-Fa-f]+)", section)
            if m_obj:
                index, sub = int(m_obj.group(1), 16), 0
                self.object_names[index] = parser.get(section, "ParameterName", fallback=section)
                otype = int(parser.get(section, "ObjectType", fallback="0x7"), 0)
                if otype not in (0x7, 0x2):
                    continue  # ARRAY/RECORD header: its entries come in <index>sub<n> sections
            elif m_sub:
                index, sub = int(m_sub.group(1), 16), int(m_sub.group(2), 16)
            else:
                continue
            self._add(parser, section, index, sub, top=bool(m_obj))
        for (index, sub), v in list(self.vars.items()):
            if v.key:
                self.by_key[v.key] = v  # a VAR object
                continue
            sub_name_count[v.name] = sub_name_count.get(v.name, 0) + 1
            v = replace(v, key=f"{self.object_names.get(index, f'0x{index:04X}')}.{v.name}")
            self.vars[(index, sub)] = v
            self.by_key[v.key] = v
        # entry names that are unique across the dictionary are keys too (theta3, flux_coeff2)
        for (index, sub), v in self.vars.items():
            if v.key != v.name and sub_name_count.get(v.name) == 1 and v.name not in self.by_key:
                self.by_key[v.name] = v

    def _add(self, parser: RawConfigParser, section: str, index: int, sub: int, *, top: bool) -> None:
        where = f"{self.path}: [{section}]"

        def get(key: str, default: str = "") -> str:
            return parser.get(section, key, fallback=default)

        try:
            data_type = int(get("DataType", "0"), 0)
        except ValueError:
            raise EdsError(
                f"{where} DataType: expected a type code like 0x0008, got {get('DataType')!r}"
            ) from None
        low = parser.get(section, "LowLimit", fallback=None)
        high = parser.get(section, "HighLimit", fallback=None)
        info = VarInfo(
            index=index,
            subindex=sub,
            name=get("ParameterName", section),
            key=(get("ParameterName", section) or section) if top else "",
            data_type=data_type,
            access=(get("AccessType", "ro") or "ro").lower(),
            unit=get("Unit", "") or "",
            low=None if not low else _number(low, data_type, f"{where} LowLimit"),
            high=None if not high else _number(high, data_type, f"{where} HighLimit"),
            default=get("DefaultValue", "") or "",
            pdo_mappable=bool(int(get("PDOMapping", "0"), 0)),
            description=get("Description", "") or "",
        )
        if info.low is not None and info.high is not None and info.low > info.high:
            raise EdsError(f"{where}: LowLimit {info.low} is above HighLimit {info.high}")
        self.vars[(index, sub)] = info

    def get(self, key: ObjectKey) -> VarInfo:
        """The variable named by ``key`` (see module docstring); KeyError with suggestions if unknown."""
        index_sub = parse_index_key(key)
        if index_sub is not None:
            if index_sub in self.vars:
                return self.vars[index_sub]
            raise KeyError(f"{self.path.name}: no object 0x{index_sub[0]:04X} sub {index_sub[1]}")
        assert isinstance(key, str)
        if key in self.by_key:
            return self.by_key[key]
        lowered = {k.lower(): v for k, v in self.by_key.items()}
        if key.lower() in lowered:
            return lowered[key.lower()]
        close = [k for k in self.by_key if key.lower() in k.lower()][:8]
        hint = f"; did you mean {', '.join(close)}?" if close else ""
        raise KeyError(f"{self.path.name}: no object named {key!r}{hint}")

    def check(self, info: VarInfo, value: float | int) -> int | None:
        """The SDO abort code a write of ``value`` to ``info`` earns, or None if it is in range.

        0x06090030 value range exceeded (NaN for a REAL), 0x06090031 too high, 0x06090032 too low.
        """
        if isinstance(value, float) and math.isnan(value):
            return ABORT_RANGE if (info.low is not None or info.high is not None) else None
        if info.high is not None and value > info.high:
            return ABORT_TOO_HIGH
        if info.low is not None and value < info.low:
            return ABORT_TOO_LOW
        return None


def parse_index_key(key: ObjectKey) -> tuple[int, int] | None:
    """``0x2200`` / ``0x1018sub1`` / ``0x1018:1`` / ``0x1018.1`` / (index, sub) / int -> (index, sub);
    else None."""
    if isinstance(key, tuple):
        return int(key[0]), int(key[1])
    if isinstance(key, int):
        return key, 0
    m = re.fullmatch(r"\s*(0x[0-9A-Fa-f]{1,4})(?:(?:sub|:|\.)(0x[0-9A-Fa-f]+|\d+))?\s*", key)
    if not m:
        return None
    return int(m.group(1), 16), int(m.group(2), 0) if m.group(2) else 0


def load(path: str | Path) -> EdsInfo:
    """Read ``path`` (an EDS file); raises EdsError naming the file and section on bad content."""
    return EdsInfo(path)
