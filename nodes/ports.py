"""What a part of the node runtime reads of its node, where it is too much, or too late-bound, to pass as
constructor arguments: one narrow :class:`typing.Protocol` per such part, listing exactly what it reads
(the node runtime satisfies each; no part imports the runtime).

- :class:`CycleHost`: the control cycle (:mod:`nodes.cycle`) reads the device and the peer link, which
  exist or are renewed at power-on, and the SYNC number of the cycle it runs;
- the SYNC producer's is :class:`nodes.producer.ProducerHost`, beside it.
"""

from __future__ import annotations

from typing import Protocol

from telethermo.device.device import Device
from telethermo.recording.journal import CsvRecorder

from telethermo.nodes.ident_service import IdentService
from telethermo.nodes.model_slot import ModelSlot
from telethermo.nodes.param_slot import ParamSlot
from telethermo.nodes.parts import NodeParts
from telethermo.nodes.peer import PeerLink
from telethermo.nodes.stats import RuntimeStats


class CycleHost(Protocol):
    """What one control cycle reads of its node."""

    device: Device | None
    """Set at start."""
    peer: PeerLink
    """A new link at each power-on."""
    sync_cycle: int
    """The SYNC cycle being run (-1 before the first)."""
    settings: ParamSlot
    models: ModelSlot
    ident: IdentService
    parts: NodeParts
    stats: RuntimeStats
    recorder: CsvRecorder | None
    record_timing: bool
    prefix: str
    """The recording's column prefix of this side: "m" or "s"."""
    peer_id: int
    produce_sync: bool
    lockstep: bool

    def rig_counters(self) -> RuntimeStats:
        """The rig driver's counters (input timeouts, module restarts) copied into ``stats``."""
        ...
