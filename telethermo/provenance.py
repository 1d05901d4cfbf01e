"""Where a result came from: the machine, the versions, the date and the git commit of a run.

Every benchmark result file and the stress / conformance results the tests write carry it, so results
from different runs (and from the benchmarks and the tests) are comparable.
"""

from __future__ import annotations

import datetime as _dt
import os
import platform
import subprocess
from importlib import metadata
from pathlib import Path
from typing import Any

_HERE = Path(__file__).resolve().parent


def provenance() -> dict[str, Any]:
    """Machine, versions, date and commit of this run (commit "unknown" outside a git checkout)."""

    def version(pkg: str) -> str:
        try:
            return metadata.version(pkg)
        except metadata.PackageNotFoundError:
            return "not installed"

    try:
        commit = (
            subprocess.run(
                ["git", "rev-parse", "HEAD"], capture_output=True, text=True, cwd=_HERE, timeout=10
            ).stdout.strip()
            or "unknown"
        )
        dirty = bool(
            subprocess.run(
                ["git", "status", "--porcelain"], capture_output=True, text=True, cwd=_HERE, timeout=10
            ).stdout.strip()
        )
    except (OSError, subprocess.SubprocessError):
        commit, dirty = "unknown", False
    return {
        "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "commit": commit,
        "dirty_tree": dirty,
        "machine": {
            "platform": platform.platform(),
            "processor": platform.machine(),
            "cpus": os.cpu_count(),
            "python": platform.python_version(),
        },
        "versions": {p: version(p) for p in ("telethermo", "numpy", "scipy", "python-can", "canopen")},
    }
