"""The losses of a controller that its I/O module reported, read from the programs' --log files (issue 24,
robustness): how many restarts the controller owes.

The driver starts its module (OPERATIONAL, watching the controller for 150 ms) before the controller's own
start-up is over. A controller starved then (a loaded machine) is lost before its session runs, and the
session's NMT START to every node starts that module again: no restart of the controller's, which restarts a
module only while it runs (telethermo.iomodule.restart). A loss just before the session's start may be
answered either way; every loss after it is the controller's to repair."""

from __future__ import annotations

from datetime import datetime
from pathlib import Path


def stamp(line: str) -> datetime:
    """The time stamp of a line of a program's --log file (logging's default asctime, the machine's clock)."""
    return datetime.strptime(line[:23], "%Y-%m-%d %H:%M:%S,%f")


def losses(module_log: Path, node_id: int, controller_log: Path | None = None) -> int:
    """The losses of ``node_id`` the module reported (its output into the error state; 0x1029: to
    PRE-OPERATIONAL); with ``controller_log``: only those after the controller went OPERATIONAL (its session
    began)."""
    lines = [ln for ln in module_log.read_text().splitlines() if f"(node {node_id} lost)" in ln]
    if controller_log is None:
        return len(lines)
    began = next(
        stamp(ln)
        for ln in controller_log.read_text().splitlines()
        if "NMT PRE_OPERATIONAL -> OPERATIONAL" in ln
    )
    return sum(1 for ln in lines if stamp(ln) > began)


def restarts(controller_log: Path) -> int:
    """The restarts (NMT START to a module that had left OPERATIONAL) the controller's log names."""
    return controller_log.read_text().count("NMT START sent (restart")
