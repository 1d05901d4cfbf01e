"""The object-dictionary entries the EDS generator writes: CiA 301 data types, a variable (``Var``) and an
object (``Obj``), and their constructors (REAL32/REAL64/UNSIGNED with limits, PDO flag, description)."""

from __future__ import annotations

from dataclasses import dataclass, field

from telethermo.units import SUFFIXES, unit_of_name


# CiA 301 data types
BOOLEAN, INTEGER8, INTEGER16, INTEGER32 = 0x0001, 0x0002, 0x0003, 0x0004
UNSIGNED8, UNSIGNED16, UNSIGNED32, REAL32, VISIBLE_STRING = 0x0005, 0x0006, 0x0007, 0x0008, 0x0009
REAL64 = 0x0011

#: name suffix -> ASCII unit for the Unit= key: the naming rule of the one unit table
UNIT_TEXT = dict(SUFFIXES)


@dataclass(frozen=True)
class Var:
    """One variable (a VAR object, or one sub-entry of an ARRAY/RECORD)."""

    name: str
    data_type: int
    access: str  # ro, wo, rw, rwr, rww, const
    default: str
    low: str | None = None
    high: str | None = None
    pdo: bool = False
    description: str = ""
    unit_text: str = ""
    """The unit given by the parameter table (bus_config/partable.py); else implied by the name's suffix."""

    @property
    def unit(self) -> str:
        return self.unit_text or unit_of_name(self.name)


@dataclass(frozen=True)
class Obj:
    """An object: a VAR (``var``) or an ARRAY/RECORD (``subs``, sub-index -> Var)."""

    index: int
    name: str
    var: Var | None = None
    subs: dict[int, Var] = field(default_factory=dict)
    object_type: int = 0x7  # 0x7 VAR, 0x8 ARRAY, 0x9 RECORD


def _f(x: float) -> str:
    return repr(float(x))


def _real(name, access, default, low=None, high=None, pdo=False, description=""):
    return Var(
        name,
        REAL32,
        access,
        _f(default),
        None if low is None else _f(low),
        None if high is None else _f(high),
        pdo,
        description,
    )


def _real64(name, access, default, low=None, high=None, description=""):
    """A REAL64 entry: identified model coefficients cancel to ~1e-8 (see docs/identification.md), so
    REAL32 would make a transferred NARMA model unstable; they are SDO-only (never PDO-mapped)."""
    return Var(
        name,
        REAL64,
        access,
        _f(default),
        None if low is None else _f(low),
        None if high is None else _f(high),
        False,
        description,
    )


def _uint(name, data_type, access, default, low=None, high=None, pdo=False, description=""):
    return Var(
        name,
        data_type,
        access,
        f"0x{default:X}" if isinstance(default, int) else default,
        None if low is None else f"0x{low:X}",
        None if high is None else f"0x{high:X}",
        pdo,
        description,
    )


def array_obj(index: int, name: str, entries: list[Var], sub0_access: str = "const") -> Obj:
    """An ARRAY object (CiA 301 type 0x8): sub 0 "Highest sub-index supported" (UNSIGNED8, ``sub0_access``)
    reads the number of ``entries``, which are subs 1..n."""
    count = _uint("Highest sub-index supported", UNSIGNED8, sub0_access, len(entries))
    return Obj(index, name, object_type=0x8, subs={0: count, **dict(enumerate(entries, 1))})
