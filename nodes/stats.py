"""What a node counts while it runs (printed at exit, partly in the OD): one object shared by the
runtime and the parts that count (the control cycle, the fallback cycles, the SYNC producer, ...)."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class RuntimeStats:
    """What a node counted (printed at exit, partly in the OD)."""

    cycles: int = 0
    late_cycles: int = 0
    lockstep_timeouts: int = 0
    emcy_raised: int = 0
    peer_resumes: int = 0
    nmt_starts_sent: int = 0
    cycle_errors: int = 0
    fallback_cycles: int = 0
    input_timeouts: int = 0
    """Rig reads that waited out the rig's input timeout (``--rig io``: ``input_timeout_ms``, lockstep
    2.5 s) and reused the last inputs."""
    module_restarts: int = 0
    """NMT STARTs sent to an I/O module that left OPERATIONAL while this node ran (``--rig io``)."""
    latencies_s: list[float] = field(default_factory=list)
    """SYNC producer: SYNC sent -> first peer TPDO1 received, s (one per cycle with a PDO)."""
    cycle_s: list[float] = field(default_factory=list)
    """Wall time of this node's own control cycle (SYNC handler), s."""
