"""The bytes of an SDO transfer <-> the value of an EDS variable (CiA 301 basic data types, little-endian)."""
from __future__ import annotations

import struct
from typing import Any

from telethermo.canopen_dev.eds_info import VarInfo
from telethermo.remote.errors import Failure

#: CiA 301 data type code -> its encoding (BOOLEAN .. UNSIGNED64; VISIBLE_STRING and others: none)
STRUCTS = {0x0001: struct.Struct("<?"), 0x0002: struct.Struct("<b"), 0x0003: struct.Struct("<h"),
           0x0004: struct.Struct("<i"), 0x0005: struct.Struct("<B"), 0x0006: struct.Struct("<H"),
           0x0007: struct.Struct("<I"), 0x0008: struct.Struct("<f"), 0x0011: struct.Struct("<d"),
           0x0015: struct.Struct("<q"), 0x001B: struct.Struct("<Q")}


def struct_of(info: VarInfo) -> struct.Struct | None:
    """The encoding of ``info``'s data type, or None for a type without a fixed size (strings, domains)."""
    return STRUCTS.get(info.data_type)


def decode(info: VarInfo, data: bytes) -> Any:
    """An uploaded value: a number or bool, a text for VISIBLE_STRING, else the hex of the bytes; Failure if
    the node sent fewer bytes than the type has."""
    st = struct_of(info)
    if st is not None:
        if len(data) < st.size:
            raise Failure(f"0x{info.index:04X}:{info.subindex:02X} {info.key}: {len(data)} bytes, "
                          f"expected {st.size} for {info.type_name}")
        return st.unpack_from(data)[0]
    if info.data_type == 0x0009:
        return data.decode("ascii", "replace").rstrip("\x00")
    return data.hex()
