"""PDO service of the device: compile communication + mapping parameters into cheap send/receive plans.

CiA 301 behaviour implemented here (canopen's LocalNode has none of it):

- TPDO transmission types: 0 (acyclic synchronous: on the next SYNC after ``trigger``), 1..240 (every
  n-th SYNC, counted from entering OPERATIONAL or from the SYNC start value when the SYNC has a
  counter), 254/255 (event-driven: on ``trigger`` and on the event timer, honouring the inhibit
  time). Data are taken from the object dictionary at transmission time.
- RPDO transmission types 0..240: the received data are written into the object dictionary at the
  next SYNC (synchronous); 254/255: at once. A frame whose length differs from the mapped length
  is counted as malformed and ignored. RPDO event timer (sub 5, ms): deadline monitoring from the first
  RPDO received in OPERATIONAL (as CANopenNode): EMCY 0x8250 when the next one is late, cleared by it.
- Mapping granularity is 8 bits: every mapped entry covers its whole object (EDS Granularity=8).

Plans are rebuilt whenever an SDO write changes a PDO parameter (dynamic mapping).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from typing import Any, cast

from canopen import LocalNode, SdoAbortedError
from canopen.objectdictionary import ODVariable

from telethermo.cia301 import ABORT_CANNOT_MAP, ABORT_INCOMPATIBLE, ABORT_PDO_TOO_LONG, ABORT_RANGE

PDO_INVALID = 1 << 31
RTR_NOT_ALLOWED = 1 << 30
Store = dict[int, dict[int, bytes]]  # LocalNode.data_store: index -> subindex -> raw little-endian bytes


@dataclass(slots=True, eq=False)
class PdoPlan:
    """One PDO channel compiled from its communication and mapping records."""

    number: int  # 1-based
    tx: bool
    comm_index: int
    map_index: int
    cob_id: int = 0
    valid: bool = False
    trans_type: int = 255
    inhibit_100us: int = 0
    event_timer_ms: int = 0
    sync_start: int = 0
    entries: list[tuple[int, int, int]] = field(default_factory=list)  # (index, sub, bytes)
    cells: list[tuple[dict[int, bytes], int]] = field(default_factory=list)  # (data_store[index], sub)
    names: tuple[str, ...] = ()
    decoders: tuple[struct.Struct | None, ...] = ()
    length: int = 0  # bytes
    # run-time state
    countdown: int = 0
    waiting_start: bool = False
    triggered: bool = False
    last_sent: float = -1e18
    pending: bytes | None = None  # synchronous RPDO data awaiting the next SYNC
    bad_length: bool = False  # an EMCY for a length error is outstanding
    last_rx: float | None = None  # RPDO: clock time of the last one accepted (None: not monitored)
    timed_out: bool = False  # RPDO: its EMCY 0x8250 is outstanding

    @property
    def synchronous(self) -> bool:
        return self.trans_type <= 240

    def pack(self) -> bytes:
        """The TPDO payload from the current object dictionary values."""
        return b"".join([cell[sub] for cell, sub in self.cells])

    def unpack_into_store(self, data: bytes) -> None:
        """Write an RPDO payload into the object dictionary."""
        offset = 0
        for cell, sub in self.cells:
            n = len(cell[sub])
            cell[sub] = bytes(data[offset : offset + n])
            offset += n

    def decode(self, data: bytes) -> dict[str, float | int | bytes]:
        """Named values of a payload (for callbacks; bytes for an entry without a number format)."""
        out: dict[str, float | int | bytes] = {}
        offset = 0
        for name, dec, (_, _, n) in zip(self.names, self.decoders, self.entries):
            out[name] = (
                dec.unpack_from(data, offset)[0] if dec is not None else bytes(data[offset : offset + n])
            )
            offset += n
        return out


def read_u(store: Store, index: int, sub: int) -> int:
    return int.from_bytes(store[index][sub], "little")


def compile_plan(plan: PdoPlan, store: Store, node: LocalNode) -> None:
    """Fill ``plan`` from the communication/mapping records in ``store`` (LocalNode.data_store).

    Raises SdoAbortedError (0x06040041/42) if the mapping names an object that cannot be mapped
    or is too long; the caller refuses the SDO write that led here.
    """
    cob = read_u(store, plan.comm_index, 1)
    plan.valid = not cob & PDO_INVALID
    plan.cob_id = cob & 0x7FF if not cob & (1 << 29) else cob & 0x1FFFFFFF
    plan.trans_type = read_u(store, plan.comm_index, 2)
    comm = store[plan.comm_index]
    plan.inhibit_100us = read_u(store, plan.comm_index, 3) if 3 in comm else 0
    plan.event_timer_ms = read_u(store, plan.comm_index, 5) if 5 in comm else 0
    plan.sync_start = read_u(store, plan.comm_index, 6) if 6 in comm else 0
    count = read_u(store, plan.map_index, 0)
    entries: list[tuple[int, int, int]] = []
    cells: list[tuple[dict[int, bytes], int]] = []
    names: list[str] = []
    decoders: list[struct.Struct | None] = []
    total = 0
    for i in range(1, count + 1):
        if i not in store[plan.map_index]:
            raise SdoAbortedError(ABORT_PDO_TOO_LONG)
        value = read_u(store, plan.map_index, i)
        index, sub, bits = value >> 16, (value >> 8) & 0xFF, value & 0xFF
        var = mappable(node, index, sub, bits, tx=plan.tx)
        nbytes = bits // 8
        total += nbytes
        if total > 8:
            raise SdoAbortedError(ABORT_PDO_TOO_LONG)
        entries.append((index, sub, nbytes))
        cells.append((store[index], sub))
        names.append(var.name)
        fmt = getattr(var, "STRUCT_TYPES", {}).get(var.data_type)
        decoders.append(fmt)
    plan.entries, plan.cells, plan.names, plan.decoders = entries, cells, tuple(names), tuple(decoders)
    plan.length = total


def mappable(node: LocalNode, index: int, sub: int, bits: int, *, tx: bool) -> ODVariable:
    """The ODVariable at index:sub if it may be mapped with ``bits`` bits, else SdoAbortedError 0x06040041."""
    od = node.object_dictionary
    if index not in od:
        raise SdoAbortedError(ABORT_CANNOT_MAP)
    var: Any = od[index]  # an ODVariable, or an ODRecord/ODArray holding it
    if not hasattr(var, "data_type"):
        if sub not in var:
            raise SdoAbortedError(ABORT_CANNOT_MAP)
        var = var[sub]
    elif sub != 0:
        raise SdoAbortedError(ABORT_CANNOT_MAP)
    if not var.pdo_mappable or bits != len(var) or bits % 8:
        raise SdoAbortedError(ABORT_CANNOT_MAP)
    if tx and not var.readable or (not tx and not var.writable):
        raise SdoAbortedError(ABORT_CANNOT_MAP)
    return cast(ODVariable, var)


def check_comm_write(plan: PdoPlan, sub: int, new: int) -> None:
    """CiA 301 rules for writing a PDO communication parameter (raises SdoAbortedError)."""
    if sub == 1:
        if plan.valid and not new & PDO_INVALID and (new & 0x1FFFFFFF) != plan.cob_id:
            raise SdoAbortedError(ABORT_RANGE)  # COB-ID may change only while the PDO is invalid
        if not new & (1 << 29) and (new & 0x7FF) in (0, 0x80) and not new & PDO_INVALID:
            raise SdoAbortedError(ABORT_RANGE)  # NMT/SYNC identifiers are not PDO identifiers
    elif sub == 2:
        # 0..240 synchronous, 254/255 event-driven; 241..251 are reserved and 252/253 (RTR-only)
        # are not supported by this device
        if not (0 <= new <= 240 or new in (254, 255)):
            raise SdoAbortedError(ABORT_RANGE)
    elif sub == 3 and plan.valid:
        raise SdoAbortedError(ABORT_INCOMPATIBLE)  # inhibit time only while invalid (CiA 301 7.5.2.35)
    elif sub == 6 and (new > 240 or plan.valid):  # SYNC start value only while invalid (as CANopenNode)
        raise SdoAbortedError(ABORT_RANGE)
