"""A remote node's transmit PDO, reconfigured by SDO as CiA 301 §7.5.2.36 prescribes (PDO invalid while its
mapping changes) and put back from what was read before."""

from __future__ import annotations

from dataclasses import dataclass

from telethermo.remote.client import NodeClient

PDO_INVALID = 1 << 31  # bit 31 of the COB-ID entry: the PDO does not exist


@dataclass(frozen=True)
class TpdoSettings:
    """One TPDO: its communication record (``comm``, 0x1800..) and mapping record (``mapping``, 0x1A00..),
    COB-ID entry (sub 1, valid bit included), transmission type (sub 2) and mapping entries (index << 16 |
    sub << 8 | bits)."""

    comm: int
    mapping: int
    cob_id: int
    transmission_type: int
    entries: tuple[int, ...]

    @property
    def can_id(self) -> int:
        return self.cob_id & 0x7FF


def read_tpdo(client: NodeClient, comm: int, mapping: int) -> TpdoSettings:
    """The TPDO's parameters as the node holds them now."""
    n = client.raw_get(mapping, 0)
    return TpdoSettings(
        comm,
        mapping,
        client.raw_get(comm, 1),
        client.raw_get(comm, 2),
        tuple(client.raw_get(mapping, k) for k in range(1, n + 1)),
    )


def configure_writes(s: TpdoSettings) -> list[tuple[int, int, int]]:
    """The SDO writes (index, sub, value) that give a TPDO the settings ``s``, in order: invalid, mapping
    emptied, entries, entry count, transmission type, then the COB-ID of ``s`` (valid or not,
    as ``s`` says)."""
    writes = [(s.comm, 1, s.cob_id | PDO_INVALID), (s.mapping, 0, 0)]
    writes += [(s.mapping, k, e) for k, e in enumerate(s.entries, start=1)]
    writes += [(s.mapping, 0, len(s.entries)), (s.comm, 2, s.transmission_type), (s.comm, 1, s.cob_id)]
    return writes


def remapped(saved: TpdoSettings, entries: list[int], transmission_type: int) -> TpdoSettings:
    """``saved``'s PDO, valid, on its own COB-ID, with new ``entries`` and ``transmission_type``."""
    return TpdoSettings(
        saved.comm, saved.mapping, saved.cob_id & ~PDO_INVALID, transmission_type, tuple(entries)
    )


def configure(client: NodeClient, s: TpdoSettings) -> None:
    """Write :func:`configure_writes` of ``s``; the first failure stops (Failure/UserError)."""
    for index, sub, value in configure_writes(s):
        client.raw_set(index, sub, value)
