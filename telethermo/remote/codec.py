"""The bytes of an SDO transfer <-> a value (CiA 301 basic data types, little-endian): by an EDS variable's
type (:func:`decode`), or by a type the operator names (``--type u16``: :func:`encode_as`, :func:`decode_as`)
for a node without an EDS; :func:`raw_text` for bytes of unknown type."""

from __future__ import annotations

import struct
from typing import Any

from canopen.objectdictionary import ODVariable
from canopen.objectdictionary import datatypes as dt

from telethermo.device.eds_info import VarInfo
from telethermo.remote.errors import Failure, UserError

#: the fixed-size CiA 301 types a value can be given as (``--type``)
_TYPE_CODES = {
    "u8": dt.UNSIGNED8,
    "u16": dt.UNSIGNED16,
    "u32": dt.UNSIGNED32,
    "u64": dt.UNSIGNED64,
    "i8": dt.INTEGER8,
    "i16": dt.INTEGER16,
    "i32": dt.INTEGER32,
    "i64": dt.INTEGER64,
    "f32": dt.REAL32,
    "f64": dt.REAL64,
}
#: CiA 301 data type code -> its encoding, from canopen's own table (ODVariable.STRUCT_TYPES): BOOLEAN and the
#: types above; VISIBLE_STRING and the others have none
STRUCTS = {code: ODVariable.STRUCT_TYPES[code] for code in (dt.BOOLEAN, *_TYPE_CODES.values())}
#: CiA 301 data type code -> its name, from canopen's datatypes module
_NAMES = {v: n for n in dir(dt) if n.isupper() and isinstance(v := getattr(dt, n), int)}


def struct_of(info: VarInfo) -> struct.Struct | None:
    """The encoding of ``info``'s data type, or None for a type without a fixed size (strings, domains)."""
    return STRUCTS.get(info.data_type)


def decode(info: VarInfo, data: bytes) -> Any:
    """An uploaded value: a number or bool, a text for VISIBLE_STRING, else the hex of the bytes; Failure if
    the node sent fewer bytes than the type has."""
    st = struct_of(info)
    if st is not None:
        if len(data) < st.size:
            raise Failure(
                f"0x{info.index:04X}:{info.subindex:02X} {info.key}: {len(data)} bytes, "
                f"expected {st.size} for {info.type_name}"
            )
        return st.unpack_from(data)[0]
    if info.data_type == 0x0009:
        return data.decode("ascii", "replace").rstrip("\x00")
    return data.hex()


#: --type -> (struct format or None for text, CiA 301 type name)
TYPES: dict[str, tuple[str | None, str]] = {
    name: (STRUCTS[code].format, _NAMES[code]) for name, code in _TYPE_CODES.items()
} | {"str": (None, "VISIBLE_STRING")}
#: CiA 301 data type code of an EDS entry -> --type
EDS_TYPES = {dt.BOOLEAN: "u8", dt.VISIBLE_STRING: "str"} | {code: name for name, code in _TYPE_CODES.items()}


def encode_as(type_name: str, text: str) -> bytes:
    """VALUE as the bytes of ``type_name``; UserError naming what was expected."""
    fmt, cia = TYPES[type_name]
    if fmt is None:
        try:
            return text.encode("ascii")
        except UnicodeEncodeError:
            raise UserError(f"value {text!r}: expected ASCII text for a {cia}") from None
    try:
        value: Any = float(text) if type_name.startswith("f") else int(text, 0)
    except ValueError:
        raise UserError(
            f"value {text!r}: expected a {'number' if type_name.startswith('f') else 'whole number'} "
            f"for a {cia}"
        ) from None
    try:
        return struct.pack(fmt, value)
    except (struct.error, OverflowError):
        size = struct.calcsize(fmt)
        lo, hi = (
            (0, (1 << 8 * size) - 1)
            if type_name.startswith("u")
            else (-(1 << 8 * size - 1), (1 << 8 * size - 1) - 1)
        )
        raise UserError(f"value {text}: does not fit a {cia} ({lo}..{hi})") from None


def decode_as(type_name: str, data: bytes) -> str:
    """The uploaded bytes read as ``type_name``; Failure if their size does not fit."""
    fmt, cia = TYPES[type_name]
    if fmt is None:
        return repr(data.decode("ascii", "replace").rstrip("\x00"))
    if len(data) != struct.calcsize(fmt):
        raise Failure(
            f"the node sent {len(data)} bytes ({data.hex(' ')}); a {cia} has {struct.calcsize(fmt)}"
        )
    v = struct.unpack(fmt, data)[0]
    if type_name.startswith("f"):
        return repr(v)
    return f"{v} (0x{v & ((1 << 8 * len(data)) - 1):0{2 * len(data)}X})"


def raw_text(data: bytes) -> str:
    """Bytes of unknown type: hex, and the unsigned little-endian and ASCII readings that fit."""
    text = f"{data.hex(' ') or '(no data)'} ({len(data)} byte{'s' if len(data) != 1 else ''}"
    if len(data) in (1, 2, 4, 8):
        v = int.from_bytes(data, "little")
        text += f"; as u{8 * len(data)} {v} = 0x{v:0{2 * len(data)}X}"
    stripped = data.rstrip(b"\x00")
    if len(stripped) >= 3 and all(32 <= b < 127 for b in stripped):  # a byte or two is rarely text
        text += f"; as text {stripped.decode('ascii')!r}"
    return text + ")"
