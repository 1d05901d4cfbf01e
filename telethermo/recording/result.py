"""The typed results of a run, with their JSON form (what travels on a node's stdout and into
``summary.json``):

- :class:`RunResult`: the SYNC producer's figures of its run, printed by ``telethermo-master --json`` as
  one ``result {json}`` line (:data:`RESULT_PREFIX`), read back by the launcher
  (``telethermo.nodes.launch.NodePair.result``), the session and the benchmarks;
- :class:`SessionRun`: the ``run`` block of a two-process session's ``summary.json`` (transport, wall
  time, cycles, the producer's :class:`RunResult`, the I/O modules).

``to_dict`` gives the JSON object with the keys in the order the programs have always written them, so
``to_json`` is byte for byte the line and the block they printed before they were typed;
``from_dict``/``from_json`` check the keys and the types and keep the values as they are (a round trip
gives the same bytes). Units are in the names: ``_s`` seconds, ``_ms`` milliseconds, ``_per_s`` per second.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from typing import Any

RESULT_PREFIX = "result "
"""A SYNC producer's result line on stdout: this prefix, then :meth:`RunResult.to_json`."""

_NUM = (int, float)


def _check(where: str, d: dict[str, Any], key: str, types: tuple[type, ...], optional: bool = False) -> Any:
    """``d[key]`` if it has one of ``types`` (None too with ``optional``), else a ValueError naming it."""
    if key not in d:
        raise ValueError(f"{where}: missing field {key!r}")
    v = d[key]
    if v is None and optional:
        return v
    if (isinstance(v, bool) and bool not in types) or not isinstance(v, types):
        want = " or ".join(t.__name__ for t in types) + (" or null" if optional else "")
        raise ValueError(f"{where}: field {key!r}: expected {want}, got {v!r}")
    return v


def _object(where: str, text: str) -> dict[str, Any]:
    try:
        d = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{where}: not JSON: {exc}") from None
    if not isinstance(d, dict):
        raise ValueError(f"{where}: expected a JSON object, got {type(d).__name__}")
    return d


@dataclass(frozen=True)
class RealtimeFigures:
    """The real-time ticker's figures (a ``--timing realtime`` producer only)."""

    lateness_ms_p50: float | None
    """Median lateness of a SYNC against its deadline, ms (None: no SYNC sent)."""
    lateness_ms_p99: float | None
    """99th percentile of that lateness, ms."""
    lateness_ms_max: float
    """Largest lateness, ms."""
    overruns: int
    """SYNCs skipped because a cycle overran its period."""
    late_tolerance_ms: float
    """Lateness above which a cycle counts as late, ms."""


@dataclass(frozen=True)
class IoRigCounters:
    """The I/O rig's counters (a producer on ``--rig io`` only; the OD's 0x2709 and 0x270A)."""

    input_timeouts: int
    """Rig reads that waited out the input timeout and reused the last inputs."""
    module_restarts: int
    """NMT STARTs the node sent to an I/O module that had left OPERATIONAL while it ran."""


@dataclass(frozen=True)
class RunResult:
    """The SYNC producer's figures of one run (``telethermo-master --json``'s ``result`` line)."""

    cycles: int
    """SYNC cycles run."""
    wall_s: float
    """Wall time of the cycles, s (start-up not included)."""
    cycles_per_s: float | None
    """Cycles per second of wall time (None when no time passed)."""
    timing: str
    """``"lockstep"`` or ``"realtime"``."""
    period_s: float
    """The control period, s."""
    late_cycles: int
    """Cycles whose SYNC went out late."""
    lockstep_timeouts: int
    """Lockstep cycles that went on without the peer's PDO."""
    sync_to_tpdo_ms_p50: float | None
    """Median time from a SYNC sent to the peer's first TPDO1 of that cycle, ms (None: no PDO seen)."""
    sync_to_tpdo_ms_p99: float | None
    """99th percentile of that time, ms."""
    sync_to_tpdo_n: int
    """Cycles with a peer TPDO1 (the sample of the two percentiles)."""
    cycle_ms_p50: float | None
    """Median wall time of the producer's own control cycle, ms."""
    cycle_ms_p99: float | None
    """99th percentile of that wall time, ms."""
    emcy_raised: int
    """EMCY messages the producer raised."""
    peer: dict[str, Any]
    """The peer link's counters (``pdos``, ``missed_cycles``, ``losses``, ``returns``, ``non_finite``)."""
    bus: dict[str, Any] | None
    """The reconnecting bus's counters (outages, reopens, ``down_s`` in s, ...); None without one."""
    realtime: RealtimeFigures | None = None
    """The ticker's figures (real-time timing only; their keys are absent from the JSON otherwise)."""
    io_rig: IoRigCounters | None = None
    """The I/O rig's counters (``--rig io`` only; their keys are absent from the JSON otherwise)."""

    def to_dict(self) -> dict[str, Any]:
        """The JSON object: the fields in order, then the real-time figures and the I/O rig's counters
        flattened at the end."""
        nested = ("realtime", "io_rig")
        d = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name not in nested}
        for part in (self.realtime, self.io_rig):
            if part is not None:
                d.update(dataclasses.asdict(part))
        return d

    def to_json(self) -> str:
        return json.dumps(self.to_dict())

    @classmethod
    def from_dict(cls, d: dict[str, Any], where: str = "run result") -> RunResult:
        """The result of a JSON object; ValueError naming ``where`` and the field when one is wrong."""
        rt = None
        if "overruns" in d:
            rt = RealtimeFigures(
                lateness_ms_p50=_check(where, d, "lateness_ms_p50", _NUM, optional=True),
                lateness_ms_p99=_check(where, d, "lateness_ms_p99", _NUM, optional=True),
                lateness_ms_max=_check(where, d, "lateness_ms_max", _NUM),
                overruns=_check(where, d, "overruns", (int,)),
                late_tolerance_ms=_check(where, d, "late_tolerance_ms", _NUM),
            )
        io = None
        if "input_timeouts" in d or "module_restarts" in d:
            io = IoRigCounters(
                input_timeouts=_check(where, d, "input_timeouts", (int,)),
                module_restarts=_check(where, d, "module_restarts", (int,)),
            )
        return cls(
            cycles=_check(where, d, "cycles", (int,)),
            wall_s=_check(where, d, "wall_s", _NUM),
            cycles_per_s=_check(where, d, "cycles_per_s", _NUM, optional=True),
            timing=_check(where, d, "timing", (str,)),
            period_s=_check(where, d, "period_s", _NUM),
            late_cycles=_check(where, d, "late_cycles", (int,)),
            lockstep_timeouts=_check(where, d, "lockstep_timeouts", (int,)),
            sync_to_tpdo_ms_p50=_check(where, d, "sync_to_tpdo_ms_p50", _NUM, optional=True),
            sync_to_tpdo_ms_p99=_check(where, d, "sync_to_tpdo_ms_p99", _NUM, optional=True),
            sync_to_tpdo_n=_check(where, d, "sync_to_tpdo_n", (int,)),
            cycle_ms_p50=_check(where, d, "cycle_ms_p50", _NUM, optional=True),
            cycle_ms_p99=_check(where, d, "cycle_ms_p99", _NUM, optional=True),
            emcy_raised=_check(where, d, "emcy_raised", (int,)),
            peer=_check(where, d, "peer", (dict,)),
            bus=_check(where, d, "bus", (dict,), optional=True),
            realtime=rt,
            io_rig=io,
        )

    @classmethod
    def from_json(cls, text: str, where: str = "run result") -> RunResult:
        return cls.from_dict(_object(where, text), where)

    def to_line(self) -> str:
        """The producer's stdout line (without its line end)."""
        return RESULT_PREFIX + self.to_json()

    @classmethod
    def from_line(cls, line: str, where: str = "run result") -> RunResult | None:
        """The result of a stdout line, or None when the line is not a result line."""
        if not line.startswith(RESULT_PREFIX):
            return None
        return cls.from_json(line[len(RESULT_PREFIX) :], where)


@dataclass(frozen=True)
class SessionRun:
    """The ``run`` block of a two-process session's ``summary.json``."""

    transport: str | None
    """The bus's interface (``socketcand``, ``socketcan``, ...); None when unknown."""
    wall_time_s: float
    """Wall time of the whole session, s (start-up of the processes included)."""
    cycles: int
    """Rows of the merged recording (cycles both nodes recorded)."""
    cycles_requested: int
    """Cycles the session asked for (the scene's duration over its period, or ``--duration``)."""
    cycles_per_s: float | None
    """Merged cycles per second of wall time (None when no time passed)."""
    complete: bool
    """Every requested cycle is in the merged recording."""
    master: RunResult | None
    """The SYNC producer's result (None when the master printed none, e.g. killed)."""
    io_modules: dict[str, int] | None
    """Node-ID of each side's simulated I/O module (``--io``); None without."""

    def to_dict(self) -> dict[str, Any]:
        d = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        d["master"] = self.master.to_dict() if self.master is not None else None
        return d

    def to_json(self) -> str:
        return json.dumps(self.to_dict())

    @classmethod
    def from_dict(cls, d: dict[str, Any], where: str = "session run") -> SessionRun:
        master = _check(where, d, "master", (dict,), optional=True)
        return cls(
            transport=_check(where, d, "transport", (str,), optional=True),
            wall_time_s=_check(where, d, "wall_time_s", _NUM),
            cycles=_check(where, d, "cycles", (int,)),
            cycles_requested=_check(where, d, "cycles_requested", (int,)),
            cycles_per_s=_check(where, d, "cycles_per_s", _NUM, optional=True),
            complete=_check(where, d, "complete", (bool,)),
            master=RunResult.from_dict(master, f"{where}: master") if master is not None else None,
            io_modules=_check(where, d, "io_modules", (dict,), optional=True),
        )

    @classmethod
    def from_json(cls, text: str, where: str = "session run") -> SessionRun:
        return cls.from_dict(_object(where, text), where)
