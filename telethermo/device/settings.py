"""Per-device power-on settings that override the EDS defaults (from network.toml or a program)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class DeviceSettings:
    """Values that replace EDS ``DefaultValue``s at power-on and on every NMT reset.

    ``None`` keeps the EDS default. Reset communication / reset node restore these values, not the
    EDS ones, so a node configured by network.toml stays so configured across resets.

    Attributes:
        heartbeat_producer_ms: 0x1017, ms (0 = no heartbeat).
        heartbeat_consumers: 0x1016 entries as (peer node-ID, timeout ms); at most as many as the
            EDS has entries.
        sync_producer: 0x1005 bit 30: this node produces SYNC.
        sync_period_us: 0x1006 communication cycle period, µs.
        sync_counter_overflow: 0x1019 (0 = SYNC without counter, 2..240).
        known_node_ids: node-IDs on this network; frames whose COB-ID belongs to no service of
            these nodes (nor to a broadcast service) are counted as unknown. Empty: every
            node-ID 1..127 counts as known.
        rpdo_cob_ids: COB-IDs of RPDO1, RPDO2, ... (the peer's TPDO COB-IDs when node-IDs differ
            from the EDS defaults).
    """

    heartbeat_producer_ms: int | None = None
    heartbeat_consumers: tuple[tuple[int, int], ...] | None = None
    sync_producer: bool | None = None
    sync_period_us: int | None = None
    sync_counter_overflow: int | None = None
    known_node_ids: tuple[int, ...] = ()
    rpdo_cob_ids: tuple[int, ...] | None = None

    def overrides(self) -> dict[tuple[int, int], int]:
        """(index, subindex) -> raw value, for the entries this object sets."""
        out: dict[tuple[int, int], int] = {}
        if self.heartbeat_producer_ms is not None:
            out[(0x1017, 0)] = int(self.heartbeat_producer_ms)
        if self.heartbeat_consumers is not None:
            for i, (node_id, ms) in enumerate(self.heartbeat_consumers, 1):
                out[(0x1016, i)] = (int(node_id) << 16) | int(ms)
        if self.sync_period_us is not None:
            out[(0x1006, 0)] = int(self.sync_period_us)
        if self.sync_counter_overflow is not None:
            out[(0x1019, 0)] = int(self.sync_counter_overflow)
        if self.rpdo_cob_ids is not None:
            for i, cob in enumerate(self.rpdo_cob_ids):
                out[(0x1400 + i, 1)] = int(cob)
        return out
