"""The frame watch: counts frames whose COB-ID belongs to no service of the network's nodes, and flags
29-bit frames for the service handlers (canopen dispatches by the bare identifier)."""

from __future__ import annotations

from typing import Iterable

import can

from telethermo.device.context import DeviceCore

#: COB-ID bases of the services of one node (EMCY, PDOs 1..4, SDO, heartbeat), + node-ID
NODE_SERVICE_BASES = (0x080, 0x180, 0x200, 0x280, 0x300, 0x380, 0x400, 0x480, 0x500, 0x580, 0x600, 0x700)
#: broadcast COB-IDs: NMT, SYNC, TIME, LSS
BROADCAST_COB_IDS = (0x000, 0x080, 0x100, 0x7E4, 0x7E5)


def known_cobids(node_ids: tuple[int, ...]) -> set[int]:
    """COB-IDs of the broadcast services and of every service of ``node_ids`` (empty: 1..127)."""
    ids = node_ids or tuple(range(1, 128))
    out = set(BROADCAST_COB_IDS)
    for n in ids:
        out |= {base + n for base in NODE_SERVICE_BASES}
    return out


class FrameWatch(can.Listener):
    """Counts frames of unknown COB-IDs (``stats.unknown_cobid_frames``); first in line, before
    canopen's dispatcher, it sets ``core.extended`` for the service handlers."""

    def __init__(self, core: DeviceCore, node_ids: tuple[int, ...]):
        self.core = core
        self.base = frozenset(known_cobids(node_ids))
        self.known: set[int] = set(self.base)

    def set_pdo_cobids(self, cob_ids: Iterable[int]) -> None:
        """The valid PDOs' COB-IDs are known too (they follow dynamic mapping)."""
        self.known = set(self.base) | set(cob_ids)

    def on_message_received(self, msg: can.Message) -> None:
        # called before canopen's own listener: a 29-bit frame whose ID happens to be a service's
        # (0x000, 0x601, ...) would reach that service's handler; the handlers look at this flag
        self.core.extended = msg.is_extended_id
        if msg.is_error_frame:
            return
        if msg.is_extended_id or msg.arbitration_id not in self.known:
            self.core.stats.unknown_cobid_frames += 1

    def stop(self) -> None:
        pass
