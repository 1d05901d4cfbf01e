"""Commissioning of a CiA 401 I/O module by SDO, as the controller does at start-up (issue 24 item 1):
PDO mapping (CiA 301's procedure), SYNC cycle, ADC sampling period, consumer heartbeat on the controller,
output error mode = substitute, substitute = the code of 0 A, error behaviour; every value read back.

A module that refuses a write is named with the object and the SDO abort code (:class:`CommissionError`);
so is a value that reads back otherwise than written. The object indices are CiA 401's and ours
(bus_config/io_module.eds); a real module's EDS may place its sampling period elsewhere
(``ModuleSetup.sampling_index``, None: the module has none to set).
"""

from __future__ import annotations

from dataclasses import dataclass

import canopen

from telethermo.cia301 import sdo_abort_text

PDO_INVALID = 0x80000000


class CommissionError(RuntimeError):
    """A module refused a configuration write, or read back another value; the message names both."""

    def __init__(
        self,
        message: str,
        *,
        index: int,
        subindex: int,
        code: int | None = None,
        mapped: tuple[int, int] | None = None,
    ):
        super().__init__(message)
        self.index, self.subindex, self.code = index, subindex, code
        self.mapped = mapped
        """For a refused PDO mapping entry: the (index, subindex) it mapped (the signal's object)."""


def _mapped(index: int, sub: int, value: int) -> tuple[int, int] | None:
    """The (index, subindex) a PDO mapping entry ``value`` maps (0x1600–0x17FF, 0x1A00–0x1BFF, sub >= 1)."""
    if sub >= 1 and (0x1600 <= index <= 0x17FF or 0x1A00 <= index <= 0x1BFF):
        return (value >> 16) & 0xFFFF, (value >> 8) & 0xFF
    return None


def _entry(index: int, sub: int, bits: int = 16) -> int:
    return (index << 16) | (sub << 8) | bits


@dataclass(frozen=True)
class ModuleSetup:
    """What is written into one module.

    Attributes:
        node_id: the module's node-ID.
        controller_id: the node the module's heartbeat consumer (0x1016:1) watches.
        consumer_ms: its consumer heartbeat time, ms.
        cycle_period_us: 0x1006, the SYNC period, µs.
        sampling_ms: ADC sampling period, ms (at most the loop period).
        substitute_counts: 0x6444:1, the output code of 0 A (0 for a 0 V = 0 A amplifier).
        error_behaviour: 0x1029:1 (0 PRE-OPERATIONAL, 1 no change, 2 STOPPED).
        tpdos: per TPDO (1, 2, ...), the (index, sub) of 16-bit inputs it carries, sent on every SYNC.
        rpdo1: the (index, sub) of the 16-bit output the module's RPDO1 writes (None: an input module; then
            no output object is written, neither 0x6443/0x6444).
        sampling_index: the sampling-period object (None: none to set).
    """

    node_id: int
    controller_id: int
    consumer_ms: int = 150
    cycle_period_us: int = 10_000
    sampling_ms: int = 10
    substitute_counts: int = 0
    error_behaviour: int = 0
    tpdos: tuple[tuple[tuple[int, int], ...], ...] = (
        ((0x6401, 1), (0x6401, 2), (0x6401, 3), (0x6401, 4)),
        ((0x6401, 5), (0x6401, 6), (0x2101, 0)),
    )
    rpdo1: tuple[int, int] | None = (0x6411, 1)
    sampling_index: int | None = 0x2100

    def writes(self) -> list[tuple[int, int, int]]:
        """(index, sub, value) in the order they are written (each PDO: invalid, mapping, type, valid)."""
        out: list[tuple[int, int, int]] = [(0x1006, 0, self.cycle_period_us)]
        if self.sampling_index is not None:
            out.append((self.sampling_index, 0, self.sampling_ms))
        pdos = [
            (0x1800 + i, 0x1A00 + i, 0x180 + 0x100 * i + self.node_id, 1, m) for i, m in enumerate(self.tpdos)
        ]
        if self.rpdo1 is not None:
            pdos.append((0x1400, 0x1600, 0x200 + self.node_id, 255, (self.rpdo1,)))
        for comm, mapping, cob, ttype, entries in pdos:
            out.append((comm, 1, cob | PDO_INVALID))
            out.append((mapping, 0, 0))
            out += [(mapping, k, _entry(i, s)) for k, (i, s) in enumerate(entries, 1)]
            out += [(mapping, 0, len(entries)), (comm, 2, ttype), (comm, 1, cob)]
        if self.rpdo1 is not None:
            out += [(0x6443, 1, 1), (0x6444, 1, self.substitute_counts)]
        out += [(0x1029, 1, self.error_behaviour), (0x1016, 1, (self.controller_id << 16) | self.consumer_ms)]
        return out


def _name(node: canopen.RemoteNode, index: int, sub: int) -> str:
    where = f"0x{index:04X}:{sub}"
    try:
        return f"{where} ({_var(node, index, sub).name})"
    except KeyError:
        return where


def commission(node: canopen.RemoteNode, setup: ModuleSetup) -> list[tuple[int, int, int]]:
    """Write ``setup`` into the module by SDO (PRE-OPERATIONAL: PDO mapping may change) and read every
    object back; returns the final (index, sub, value) read back. Raises :class:`CommissionError`."""
    writes = setup.writes()
    for index, sub, value in writes:
        try:
            _var(node, index, sub)
        except KeyError:
            raise CommissionError(
                f"io module {node.id}: 0x{index:04X}:{sub} is not in its EDS", index=index, subindex=sub
            ) from None
        try:
            node.sdo.download(index, sub, _encode(node, index, sub, value))
        except canopen.SdoAbortedError as exc:
            mapped = _mapped(index, sub, value)
            shown = (
                f"0x{value:08X} (maps 0x{mapped[0]:04X}:{mapped[1]}, {value & 0xFF} bit)" if mapped else value
            )
            raise CommissionError(
                f"io module {node.id}: {_name(node, index, sub)} = {shown} refused: abort "
                f"0x{exc.code:08X} ({sdo_abort_text(exc.code)})",
                index=index,
                subindex=sub,
                code=exc.code,
                mapped=mapped,
            ) from None
    final = {(i, s): v for i, s, v in writes}
    back = []
    for (index, sub), value in final.items():
        got = _decode(node, index, sub, node.sdo.upload(index, sub))
        if got != value:
            raise CommissionError(
                f"io module {node.id}: {_name(node, index, sub)} reads back {got}, written {value}",
                index=index,
                subindex=sub,
            )
        back.append((index, sub, got))
    return back


def _var(node: canopen.RemoteNode, index: int, sub: int):
    obj = node.object_dictionary[index]
    return obj if isinstance(obj, canopen.objectdictionary.ODVariable) else obj[sub]


def _encode(node: canopen.RemoteNode, index: int, sub: int, value: int) -> bytes:
    return _var(node, index, sub).encode_raw(value)


def _decode(node: canopen.RemoteNode, index: int, sub: int, data: bytes) -> int:
    return _var(node, index, sub).decode_raw(data)
