"""Real-time options for a node program on a lab PC (issue 12): the usual knobs of a soft real-time
process, each applied as far as the operating system permits, each reported in one log line.

- ``--cpu N[,M]``: pin the process to these CPUs (``os.sched_setaffinity``), away from the desktop;
- ``--rt-priority P``: SCHED_FIFO at priority P (1..99; needs CAP_SYS_NICE or an rtprio limit);
- ``--nice N``: a plain priority raise/lowering when SCHED_FIFO is not permitted;
- ``--mlock``: lock the process's memory (``mlockall(MCL_CURRENT | MCL_FUTURE)``), no page faults in a cycle;
- ``--gc freeze``: after start-up, move every existing object out of the garbage collector's reach
  (``gc.freeze()``) and raise the generation-0 threshold, so a collection in a cycle is short and rare.

A knob the system refuses is a warning, not a failure: the node still runs (a lab PC without root is
the normal case), and the late-cycle counter shows what that costs.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import gc
import os
from dataclasses import dataclass

MCL_CURRENT, MCL_FUTURE = 1, 2
GC_GEN0_THRESHOLD = 50_000


@dataclass(frozen=True, slots=True)
class RealtimeOptions:
    """What the operator asked for (None / False: leave it as the system has it)."""

    cpus: tuple[int, ...] | None = None
    rt_priority: int | None = None
    nice: int | None = None
    mlock: bool = False
    gc_freeze: bool = False


def parse_cpus(text: str) -> tuple[int, ...]:
    """``0`` or ``2,3`` -> (0,) / (2, 3); ValueError naming what was expected."""
    try:
        cpus = tuple(sorted({int(p) for p in text.split(",") if p.strip() != ""}))
    except ValueError:
        raise ValueError(f"--cpu {text!r}: expected CPU numbers, e.g. 1 or 2,3") from None
    if not cpus or min(cpus) < 0:
        raise ValueError(f"--cpu {text!r}: expected CPU numbers >= 0, e.g. 1 or 2,3")
    return cpus


def _affinity(cpus: tuple[int, ...]) -> str:
    available = os.sched_getaffinity(0)
    missing = sorted(set(cpus) - available)
    if missing:
        return (
            f"WARNING cpu: CPU {missing} not available to this process (have {sorted(available)}); left as is"
        )
    os.sched_setaffinity(0, cpus)
    return f"cpu: pinned to CPU {list(cpus)}"


def _fifo(priority: int) -> str:
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except PermissionError:
        return (
            f"WARNING rt-priority: SCHED_FIFO {priority} not permitted (needs CAP_SYS_NICE or an rtprio "
            "limit in /etc/security/limits.conf); running at normal priority"
        )
    except OSError as exc:
        return f"WARNING rt-priority: SCHED_FIFO {priority} refused ({exc.strerror or exc})"
    return f"rt-priority: SCHED_FIFO {priority}"


def _nice(n: int) -> str:
    try:
        now = os.nice(n - os.nice(0))
    except PermissionError:
        return f"WARNING nice: {n} not permitted (a negative nice needs CAP_SYS_NICE); left at {os.nice(0)}"
    return f"nice: {now}"


def _mlock() -> str:
    name = ctypes.util.find_library("c")
    libc = ctypes.CDLL(name, use_errno=True) if name else None
    if libc is None or not hasattr(libc, "mlockall"):
        return "WARNING mlock: no mlockall on this system"
    if libc.mlockall(MCL_CURRENT | MCL_FUTURE) != 0:
        err = ctypes.get_errno()
        return f"WARNING mlock: mlockall refused ({os.strerror(err)}; raise the memlock limit: ulimit -l)"
    return "mlock: memory locked (current and future pages)"


def _gc_freeze() -> str:
    gc.collect()
    gc.freeze()
    _, g1, g2 = gc.get_threshold()
    gc.set_threshold(GC_GEN0_THRESHOLD, g1, g2)
    return f"gc: {gc.get_freeze_count()} start-up objects frozen, generation-0 threshold {GC_GEN0_THRESHOLD}"


def apply_realtime(opts: RealtimeOptions) -> list[str]:
    """Apply what ``opts`` asks for; one line per knob (``WARNING ...`` when the system refused it)."""
    notes = []
    if opts.cpus is not None:
        notes.append(_affinity(opts.cpus))
    if opts.rt_priority is not None:
        notes.append(_fifo(opts.rt_priority))
    if opts.nice is not None:
        notes.append(_nice(opts.nice))
    if opts.mlock:
        notes.append(_mlock())
    if opts.gc_freeze:
        notes.append(_gc_freeze())
    return notes
