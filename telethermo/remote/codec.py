"""The bytes of an SDO transfer <-> a value (CiA 301 basic data types, little-endian): by an EDS variable's
type (:func:`decode`), or by a type the operator names (``--type u16``: :func:`encode_as`, :func:`decode_as`)
for a node without an EDS; :func:`raw_text` for bytes of unknown type."""

from __future__ import annotations

import struct
from typing import Any

from telethermo.device.eds_info import VarInfo
from telethermo.remote.errors import Failure, UserError

#: CiA 301 data type code -> its encoding (BOOLEAN .. UNSIGNED64; VISIBLE_STRING and others: none)
STRUCTS = {
    0x0001: struct.Struct("<?"),
    0x0002: struct.Struct("<b"),
    0x0003: struct.Struct("<h"),
    0x0004: struct.Struct("<i"),
    0x0005: struct.Struct("<B"),
    0x0006: struct.Struct("<H"),
    0x0007: struct.Struct("<I"),
    0x0008: struct.Struct("<f"),
    0x0011: struct.Struct("<d"),
    0x0015: struct.Struct("<q"),
    0x001B: struct.Struct("<Q"),
}


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
    "u8": ("<B", "UNSIGNED8"),
    "u16": ("<H", "UNSIGNED16"),
    "u32": ("<I", "UNSIGNED32"),
    "u64": ("<Q", "UNSIGNED64"),
    "i8": ("<b", "INTEGER8"),
    "i16": ("<h", "INTEGER16"),
    "i32": ("<i", "INTEGER32"),
    "i64": ("<q", "INTEGER64"),
    "f32": ("<f", "REAL32"),
    "f64": ("<d", "REAL64"),
    "str": (None, "VISIBLE_STRING"),
}
#: CiA 301 data type code of an EDS entry -> --type
EDS_TYPES = {
    0x0001: "u8",
    0x0002: "i8",
    0x0003: "i16",
    0x0004: "i32",
    0x0005: "u8",
    0x0006: "u16",
    0x0007: "u32",
    0x0008: "f32",
    0x0009: "str",
    0x0011: "f64",
    0x0015: "i64",
    0x001B: "u64",
}


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
