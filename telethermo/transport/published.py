"""Where a running hub or session listens: a small state file, so that a second terminal's
``telethermo get master ...`` finds the bus with no flag at all.

The file is ``$XDG_RUNTIME_DIR/telethermo/hub.json`` (or ``~/.cache/telethermo/hub.json`` where there is
no runtime dir), written atomically by ``telethermo-hub`` and ``telethermo session`` when they start and
removed when they stop; it holds the bus string, the writer's pid and what wrote it. A file whose pid
no longer runs (a hub killed with SIGKILL) is ignored.

A session (or anything that runs a hub of its own beside the user's) publishes with
``publish_if_absent``: a live writer's file is never replaced, so a ``telethermo session`` started while
a ``telethermo-hub`` runs leaves that hub findable during and after the session. Everyone removes only
the file it wrote (``unpublish`` compares the pid).
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator
from telethermo.atomic import write_json_atomic


def state_file() -> Path:
    """The state file's path for this user."""
    runtime = os.environ.get("XDG_RUNTIME_DIR")
    base = Path(runtime) if runtime and Path(runtime).is_dir() else Path.home() / ".cache"
    return base / "telethermo" / "hub.json"


@dataclass(frozen=True)
class Published:
    bus: str
    pid: int
    by: str
    path: Path


def publish(bus: str, by: str, *, pid: int | None = None) -> Path:
    """Record that ``by`` (e.g. "telethermo-hub") listens on ``bus``; returns the file written."""
    doc = {
        "bus": bus,
        "pid": pid or os.getpid(),
        "by": by,
        "since": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
    }
    return write_json_atomic(state_file(), doc)


def publish_if_absent(bus: str, by: str, *, pid: int | None = None) -> Published | None:
    """Publish ``bus`` unless a live hub or session has published already; returns that one (the file is
    left as it is) or None when this call published. The state file is created with a hard link of a
    complete temporary file, so two writers racing here cannot both win, and a reader never sees a torn
    file; a stale file (its writer gone) is replaced."""
    path = state_file()
    doc = {
        "bus": bus,
        "pid": pid or os.getpid(),
        "by": by,
        "since": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
    }
    tmp = write_json_atomic(path.with_name(f".{path.name}.{os.getpid()}.new"), doc)
    try:
        for _ in range(3):
            try:
                os.link(tmp, path)
                return None
            except FileExistsError:
                other = running()
                if other is not None:
                    return other
                try:  # a stale or damaged file: its writer is gone
                    path.unlink()
                except FileNotFoundError:
                    pass
        raise OSError(f"{path}: replaced by another writer while publishing; try again")
    finally:
        tmp.unlink(missing_ok=True)


def unpublish(*, pid: int | None = None) -> None:
    """Remove the state file if it is still ours (a later hub may have replaced it)."""
    path = state_file()
    try:
        if json.loads(path.read_text()).get("pid") == (pid or os.getpid()):
            path.unlink()
    except (OSError, ValueError, AttributeError):
        pass


@contextlib.contextmanager
def published(bus: str, by: str) -> Iterator[Path]:
    """Publish ``bus`` for the duration of the ``with`` block."""
    path = publish(bus, by)
    try:
        yield path
    finally:
        unpublish()


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process: it runs
        return True
    return True


def running() -> Published | None:
    """The bus a live hub or session published, or None (no file, a damaged one, or its writer gone)."""
    path = state_file()
    try:
        doc = json.loads(path.read_text())
        bus, pid, by = doc["bus"], doc["pid"], doc.get("by", "?")
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if (
        not isinstance(bus, str)
        or not isinstance(pid, int)
        or isinstance(pid, bool)
        or pid <= 0
        or not _alive(pid)
    ):
        return None
    return Published(bus=bus, pid=pid, by=str(by), path=path)
