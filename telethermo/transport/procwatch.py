"""Whether a process the hub watches still runs (``telethermo-hub --parent-pid``). Linux's /proc where it
exists, the null signal elsewhere."""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["process_alive"]


def process_alive(pid: int) -> bool:
    """``pid`` runs: it exists and (where /proc tells) is not a zombie that its parent has not reaped yet.

    By its PID alone, not by whether it is still this process's parent: a hub started with
    ``nohup``/``setsid`` or from a shell that is PID 1 is re-parented, or has init for its parent, while the
    process it watches runs on."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return True  # no /proc (or the process just went): the signal check stands
    return stat.rpartition(")")[2].split()[:1] != ["Z"]
