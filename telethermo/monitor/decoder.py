"""Stateless decoding of one CANopen frame: which service it belongs to, which node, which fields.

The classification follows CiA 301's predefined connection set with the corrections the common
Python tools miss: SYNC is exactly the SYNC COB-ID (0x080 by default, 0 or 1 data byte: the counter)
while EMCY is 0x081..0x0FF; PDO COB-IDs come from the mapping table (EDS plus what was seen on the
bus) before the predefined ranges are guessed; SDO requests and responses are told apart by range.
Stateful decoding (SDO transfers, PDO values, heartbeat timing) lives in :mod:`.sdo`, :mod:`.pdo`
and :mod:`.state`.
"""

from __future__ import annotations

import datetime as _dt
import struct
from dataclasses import dataclass, field
from typing import Any

from telethermo.cia301 import emcy_code_text

from telethermo import cia301

# frame kinds
NMT, SYNC, EMCY, TIME, PDO, SDO_REQ, SDO_RESP, HEARTBEAT, NODE_GUARD, LSS, ERROR_FRAME, UNKNOWN = (
    "NMT",
    "SYNC",
    "EMCY",
    "TIME",
    "PDO",
    "SDO_REQ",
    "SDO_RESP",
    "HEARTBEAT",
    "NODE_GUARD",
    "LSS",
    "ERROR_FRAME",
    "UNKNOWN",
)

KINDS = (NMT, SYNC, EMCY, TIME, PDO, SDO_REQ, SDO_RESP, HEARTBEAT, NODE_GUARD, LSS, ERROR_FRAME, UNKNOWN)

TIME_EPOCH = _dt.datetime(1984, 1, 1, tzinfo=_dt.timezone.utc)


@dataclass(slots=True)
class Frame:
    """One decoded frame.

    Attributes:
        t_s: receive timestamp, s (the bus's or the log's clock).
        cob_id: the 11-bit (or 29-bit) identifier.
        data: the payload.
        kind: one of NMT, SYNC, EMCY, TIME, PDO, SDO_REQ, SDO_RESP, HEARTBEAT, NODE_GUARD, LSS,
            ERROR_FRAME, UNKNOWN.
        node: the node the frame belongs to (producer, or addressee for NMT/SDO requests);
            0 for NMT broadcast; None if none.
        text: one human-readable line.
        fields: the decoded fields (JSON-able).
    """

    t_s: float
    cob_id: int
    data: bytes
    kind: str
    node: int | None
    text: str = ""
    fields: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {
            "t_s": self.t_s,
            "type": "frame",
            "kind": self.kind,
            "cob_id": self.cob_id,
            "node": self.node,
            "data": self.data.hex(),
            "text": self.text,
            "fields": self.fields,
        }


def classify(
    cob_id: int,
    *,
    extended: bool = False,
    remote: bool = False,
    error: bool = False,
    sync_cob_id: int = cia301.COB_SYNC,
    pdo_cob_ids: frozenset[int] | set[int] = frozenset(),
) -> tuple[str, int | None]:
    """(kind, node) of a frame from its identifier alone; see the module docstring for the order."""
    if error:
        return ERROR_FRAME, None
    if extended:
        return UNKNOWN, None
    if cob_id == cia301.COB_NMT:
        return NMT, None
    if cob_id == sync_cob_id:
        return SYNC, None
    if cob_id in pdo_cob_ids:
        return PDO, None  # the node comes from the mapping table
    if 0x081 <= cob_id <= 0x0FF:
        return EMCY, cob_id - 0x080
    if cob_id == cia301.COB_TIME:
        return TIME, None
    if 0x181 <= cob_id <= 0x57F:
        return PDO, cob_id & 0x7F or None
    if 0x581 <= cob_id <= 0x5FF:
        return SDO_RESP, cob_id - cia301.COB_SDO_TX
    if 0x601 <= cob_id <= 0x67F:
        return SDO_REQ, cob_id - cia301.COB_SDO_RX
    if 0x701 <= cob_id <= 0x77F:
        return (NODE_GUARD if remote else HEARTBEAT), cob_id - cia301.COB_HEARTBEAT
    if cob_id in (cia301.COB_LSS_TX, cia301.COB_LSS_RX):
        return LSS, None
    return UNKNOWN, None


def decode_nmt(data: bytes) -> dict[str, Any]:
    """NMT node control: command specifier and addressed node (0 = all)."""
    if len(data) != 2:
        return {"error": f"NMT frame must have 2 data bytes, got {len(data)}"}
    cs, node = data[0], data[1]
    return {
        "command": cs,
        "command_name": cia301.NMT_COMMANDS.get(cs, f"invalid 0x{cs:02X}"),
        "target": node,
        "target_state": cia301.NMT_COMMAND_TARGET.get(cs),
    }


def decode_sync(data: bytes) -> dict[str, Any]:
    """SYNC: no data, or one counter byte (1..240, CiA 301 §7.2.5)."""
    if len(data) == 0:
        return {"counter": None}
    if len(data) == 1:
        out: dict[str, Any] = {"counter": data[0]}
        if not 1 <= data[0] <= 240:
            out["error"] = f"SYNC counter {data[0]} outside 1..240"
        return out
    return {"counter": data[0], "error": f"SYNC with {len(data)} data bytes (0 or 1 expected)"}


def decode_emcy(data: bytes) -> dict[str, Any]:
    """EMCY: error code (u16), error register (u8), 5 manufacturer-specific bytes."""
    if len(data) < 3:
        return {"error": f"EMCY frame too short ({len(data)} bytes, 8 expected)"}
    code, reg = struct.unpack_from("<HB", data)
    out = {
        "code": code,
        "code_text": emcy_code_text(code),
        "register": reg,
        "register_bits": cia301.error_register_names(reg),
        "manufacturer": bytes(data[3:8]).hex(),
        "reset": code == 0,
    }
    if len(data) != 8:
        out["error"] = f"EMCY frame has {len(data)} bytes (8 expected)"
    return out


def decode_time(data: bytes) -> dict[str, Any]:
    """TIME_OF_DAY: ms after midnight (28 bits) and days since 1984-01-01 (16 bits)."""
    if len(data) != 6:
        return {"error": f"TIME frame must have 6 data bytes, got {len(data)}"}
    ms, days = struct.unpack("<IH", data)
    ms &= 0x0FFFFFFF
    when = TIME_EPOCH + _dt.timedelta(days=days, milliseconds=ms)
    return {"ms_after_midnight": ms, "days_since_1984": days, "iso": when.isoformat(timespec="milliseconds")}


def decode_heartbeat(data: bytes) -> dict[str, Any]:
    """Heartbeat / boot-up: one state byte (0 = boot-up)."""
    if len(data) != 1:
        return {"error": f"heartbeat must have 1 data byte, got {len(data)}"}
    return {
        "state": data[0] & 0x7F,
        "state_name": cia301.nmt_state_name(data[0]),
        "boot_up": data[0] == 0,
        "toggle": data[0] >> 7,
    }


def describe_emcy(f: dict[str, Any]) -> str:
    if "code" not in f:
        return f.get("error", "EMCY")
    regs = ",".join(f["register_bits"]) or "none"
    return (
        f"EMCY 0x{f['code']:04X} {f['code_text']}; register 0x{f['register']:02X} [{regs}]; "
        f"mfr {f['manufacturer']}"
    )
