"""How the pair is paced, as the bus shows it: lockstep, real time or unknown (issue 25: the monitor said
"lockstep" because the network file did, while the nodes ran in real time).

Evidence, strongest first: a node's own ``lockstep`` object (0x2704, BOOLEAN, 1 lockstep 0 real time)
seen on the bus, in an SDO upload or download (``telethermo get``, ``status``) or in a PDO it is mapped
into; else the SYNC timing: a SYNC period at the nominal one (within :data:`REALTIME_TOLERANCE`) is real
time; one well under it (below :data:`LOCKSTEP_FRACTION` of it) cannot be real time and is lockstep
(the master sends SYNC k+1 as soon as cycle k's PDOs are in). Anything else, or too few SYNCs to tell
(:data:`MIN_INTERVALS`), is "unknown": a lockstep pair slower than the period looks like late real-time
cycles.
"""

from __future__ import annotations

import statistics
from typing import Any, Iterable

#: EDS name of the nodes' timing object (0x2704 in bus_config/od_manufacturer.py)
LOCKSTEP_OBJECT = "lockstep"
MIN_INTERVALS = 20  # SYNC intervals before the timing says anything
REALTIME_TOLERANCE = 0.10  # real time: median SYNC interval within ±10 % of the nominal period
LOCKSTEP_FRACTION = 0.7  # lockstep: median interval below 70 % of the nominal period


class TimingSeen:
    """The timing evidence a monitor has met: each node's ``lockstep`` object value and how it was seen."""

    def __init__(self) -> None:
        self.by_node: dict[int, tuple[bool, str]] = {}

    def observe(self, node: int | None, name: str, value: Any, how: str) -> None:
        """Take note of an object value seen on the bus (``how``: "SDO" or a PDO label)."""
        if node is not None and name == LOCKSTEP_OBJECT and isinstance(value, (bool, int)):
            self.by_node[node] = (bool(value), how)

    def verdict(self, intervals_s: Iterable[float], nominal_s: float | None) -> tuple[bool | None, str]:
        """(True lockstep / False real time / None unknown, the evidence in words)."""
        if self.by_node:
            values = {v for v, _ in self.by_node.values()}
            said = ", ".join(
                f"node {n} {'lockstep' if v else 'real time'} ({how})"
                for n, (v, how) in sorted(self.by_node.items())
            )
            return (values.pop() if len(values) == 1 else None), f"the nodes' lockstep object: {said}"
        iv = list(intervals_s)
        if len(iv) < MIN_INTERVALS:
            return None, f"{len(iv)} SYNC intervals seen, {MIN_INTERVALS} needed to tell"
        if not nominal_s:
            return None, "no nominal SYNC period to compare with"
        median = statistics.median(iv)
        ratio = median / nominal_s
        if abs(ratio - 1.0) <= REALTIME_TOLERANCE:
            return False, f"SYNC every {median * 1e3:.2f} ms, the nominal period"
        if ratio < LOCKSTEP_FRACTION:
            return True, f"SYNC every {median * 1e3:.2f} ms, faster than the {nominal_s * 1e3:.2f} ms period"
        return None, (
            f"SYNC every {median * 1e3:.2f} ms against a {nominal_s * 1e3:.2f} ms period: "
            "a lockstep pair slower than the period, or late real-time cycles"
        )


def timing_label(lockstep: bool | None) -> str:
    return {True: "lockstep", False: "real time", None: "timing unknown"}[lockstep]
