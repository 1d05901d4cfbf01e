"""A remote node's values as the operator types and reads them: parsing a value for an object's type,
the local range check, and the formatting ``get``, ``set`` and ``status`` print (hex for COB-IDs and bit
fields, names for enumerations, the unit always) and the rule behind a refusal.

Light on purpose (``get``/``set`` import it): no numpy, only the control core's enum modules, which
import nothing but the standard library.

- **Unit**: the EDS ``Unit=`` key; else the name's unit suffix (``_C`` degC, ``_A_per_W`` A/W, ... the
  naming rule of telethermo/units.py); else a time unit the description starts with (CiA 301 objects:
  ``ms``, ``us``, ``100 us units`` -> ``x100 us``).
- **Hex**: COB-IDs (``COB-ID SYNC = 0x40000080 (COB-ID 0x080, produces SYNC)``), PDO mapping entries
  (``0x20000020 (0x2000:00 T_sensor_C, 32 bits)``), heartbeat consumer entries (``0x000200FA (node 2,
  250 ms)``), the error register (``0x19 (generic, temperature, communication)``), trip masks
  (``0x0200 (peer_lost)``), EMCY codes with their CiA 301 text (``0x8130 (Life guard error or heartbeat
  error)``, the error history 0x1003 likewise), device type, identity and CRCs; and any unsigned object
  whose description speaks of bits.
- **Enumerations**: ``mode``, ``estimator`` and ``safety_state`` of our nodes by the control core's enums
  (``1 (telepresence)``); any other object whose description is a list ``0 name, 1 name, ...``.
"""

from __future__ import annotations

import math
import re
import struct
from typing import Any

from telethermo.device.eds_info import EdsInfo, VarInfo
from telethermo.control.estimators import Estimator
from telethermo.control.safety import SafetyState, Trip
from telethermo.control.types import Mode
from telethermo.cia301 import emcy_code_text, error_register_names
from telethermo.remote.codec import struct_of
from telethermo.remote.errors import UserError
from telethermo.units import SUFFIXES, unit_of_name

#: name suffix -> unit (the naming rule of the one unit table, telethermo/units.py; longest first)
NAME_UNITS = SUFFIXES
_TIME_UNIT = re.compile(r"^(?:(\d+) )?(us|ms|s)\b( units)?")
_ENUM_ITEM = re.compile(r"^(\d+) ([A-Za-z][^()]*?)\s*(?:\(.*\))?$")
_UNSIGNED = {0x0005: 2, 0x0006: 4, 0x0007: 8, 0x001B: 16}  # data type -> hex digits


def unit_of(info: VarInfo) -> str:
    """The unit to print after a value of ``info`` ('' if dimensionless)."""
    if info.unit:
        return info.unit
    unit = unit_of_name(info.name)
    if unit:
        return unit
    m = _TIME_UNIT.match(info.description)
    if m and info.data_type in _UNSIGNED:
        return f"x{m.group(1)} {m.group(2)}" if m.group(1) else m.group(2)
    return ""


def _control_enum(name: str) -> dict[int, str]:
    """code -> name of one of our objects, from the control core's enum."""
    if name == "mode":
        return {int(m): m.name.lower() for m in Mode}
    if name == "estimator":
        # the object's codes are the enum's declaration order (tests/cli/test_cli_values.py checks the
        # node's ESTIMATOR_CODES against it)
        return {i: e.value for i, e in enumerate(Estimator)}
    return {int(s): s.name.lower() for s in SafetyState}


def enum_names(info: VarInfo, ours: bool = True) -> dict[int, str] | None:
    """code -> name of an enumerated object, or None. ``ours``: the node runs our control core."""
    if ours and info.index >= 0x2000 and info.name in ("mode", "estimator", "safety_state"):
        return _control_enum(info.name)
    if info.data_type not in _UNSIGNED and info.data_type not in (0x0002, 0x0003, 0x0004):
        return None
    text = info.description.split(":")[-1] if ":" in info.description else info.description
    items = re.split(r",\s*(?=\d+ )", text.strip())
    names: dict[int, str] = {}
    for item in items:
        m = _ENUM_ITEM.match(item.strip())
        if not m or int(m.group(1)) in names:
            return None
        names[int(m.group(1))] = m.group(2).strip()
    return names if len(names) >= 2 else None


def _is_mapping_entry(info: VarInfo) -> bool:
    return (0x1600 <= info.index <= 0x17FF or 0x1A00 <= info.index <= 0x1BFF) and info.subindex >= 1


def hex_digits(info: VarInfo) -> int | None:
    """Hex digits to show ``info``'s value with, or None to show it in decimal."""
    digits = _UNSIGNED.get(info.data_type)
    if digits is None:
        return None
    name, desc = info.name.lower(), info.description.lower()
    if (
        "cob-id" in name
        or _is_mapping_entry(info)
        or info.index in (0x1000, 0x1001)
        or (info.index in (0x1003, 0x1016, 0x1018) and info.subindex >= 1)
        or "crc" in name
        or re.search(r"\bbits? (\d|i\b)", desc)
        or "emcy code" in desc
        or "error code" in name
    ):
        return digits
    return None


def _note(info: VarInfo, value: int, eds: EdsInfo | None) -> str:
    """What a hex value means, where it is a known structure ('' if nothing to add)."""
    name = info.name.lower()
    if "cob-id" in name:
        can_id = value & (0x1FFFFFFF if value & 0x20000000 else 0x7FF)
        parts = [f"COB-ID 0x{can_id:03X}"]
        if info.index == 0x1005:
            parts.append("produces SYNC" if value & 0x40000000 else "consumes SYNC")
        elif 0x1400 <= info.index <= 0x1BFF:
            parts.append("disabled" if value & 0x80000000 else "enabled")
        elif value & 0x80000000:
            parts.append("invalid")
        return ", ".join(parts)
    if _is_mapping_entry(info):
        if value == 0:
            return "unused"
        idx, sub, bits = value >> 16, (value >> 8) & 0xFF, value & 0xFF
        target = eds.vars.get((idx, sub)) if eds is not None else None
        return f"0x{idx:04X}:{sub:02X}{' ' + target.key if target else ''}, {bits} bits"
    if info.index == 0x1016 and info.subindex >= 1:
        node, ms = (value >> 16) & 0xFF, value & 0xFFFF
        return "unused" if node == 0 or ms == 0 else f"node {node}, {ms} ms"
    if info.index == 0x1001:
        return ", ".join(error_register_names(value)) or "no error"
    if info.index == 0x1003 and info.subindex >= 1:  # error field: EMCY code in the low 16 bits
        return f"EMCY 0x{value & 0xFFFF:04X} {emcy_code_text(value & 0xFFFF)}" if value else "none"
    if "emcy code" in info.description.lower() or "error code" in name:
        return emcy_code_text(value & 0xFFFF) if value else "none"
    if info.name in ("active_trips", "fault_reset_blocked_by") and info.index >= 0x2000:
        trips = [t.value for i, t in enumerate(Trip) if value >> i & 1]
        return ", ".join(trips) or "none"
    return ""


def fmt(value: Any, info: VarInfo, eds: EdsInfo | None = None, *, ours: bool = True) -> str:
    """``value`` of ``info`` as ``get`` prints it (unit, hex, enumeration name)."""
    unit = unit_of(info)
    if isinstance(value, bool):
        return str(value)
    if isinstance(value, float):
        txt = f"{value:.4f}".rstrip("0").rstrip(".") if math.isfinite(value) else str(value)
        if txt in ("-0", ""):
            txt = "0"
        return f"{txt} {unit}".rstrip()
    if isinstance(value, int):
        names = enum_names(info, ours)
        if names is not None:
            return f"{value} ({names.get(value, 'not a listed value')})"
        digits = hex_digits(info)
        if digits is not None:
            note = _note(info, value, eds)
            return f"0x{value:0{digits}X}" + (f" ({note})" if note else "")
    return f"{value} {unit}".rstrip()


def parse_enum(info: VarInfo, text: str, ours: bool = True) -> int | None:
    """The code of an enumeration name (``telepresence`` -> 1) or None if ``text`` is not one."""
    names = enum_names(info, ours)
    if not names:
        return None
    wanted = text.strip().lower().replace("-", "_").replace(" ", "_")
    for code, name in names.items():
        if name.lower().replace("-", "_").replace(" ", "_") == wanted:
            return code
    return None


def rule_keys(info: VarInfo, eds: EdsInfo) -> list[str]:
    """The other objects ``info``'s description names (the rule a node applies across objects)."""
    words = re.findall(r"[A-Za-z_][A-Za-z0-9_]*", info.description)
    out: list[str] = []
    for w in words:
        if w != info.key and w in eds.by_key and "_" in w and w not in out:
            out.append(w)
    return out


def parse_value(info: VarInfo, text: str) -> float | int | bool:
    """Parse an operator's value for ``info``'s type; UserError naming the parameter otherwise."""
    t = text.strip()
    try:
        if info.data_type in (0x0008, 0x0011):
            v: Any = float(t)
        elif info.data_type == 0x0001:
            low = t.lower()
            if low in ("1", "true", "on", "yes"):
                return True
            if low in ("0", "false", "off", "no"):
                return False
            raise ValueError
        elif struct_of(info) is not None:
            v = int(t, 0)
        else:
            raise UserError(f"{info.key}: setting a {info.type_name} is not supported here")
    except ValueError:
        raise UserError(f"{info.key}: expected a {info.type_name} value, got {text!r}") from None
    if isinstance(v, float) and not math.isfinite(v) and not math.isnan(v):
        raise UserError(f"{info.key}: expected a finite number, got {text!r}")
    return v


def check_range(info: VarInfo, value: float | int | bool) -> None:
    """Refuse locally what the node would refuse: out of the EDS range, or out of the type's range. Every
    refusal ends with "; not sent" (callers that add context say it no more)."""
    if isinstance(value, bool):
        return
    if isinstance(value, float) and math.isnan(value):
        raise UserError(
            f"{info.key}: NaN is not a value; allowed range {info.range_text() or 'any number'}; not sent"
        )
    if info.low is not None and value < info.low or info.high is not None and value > info.high:
        raise UserError(f"{info.key} = {value:g} is out of range {info.range_text()}; not sent")
    st = struct_of(info)
    if st is not None and isinstance(value, int):
        try:
            st.pack(value)
        except struct.error:
            raise UserError(f"{info.key} = {value} does not fit a {info.type_name}; not sent") from None
