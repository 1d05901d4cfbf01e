"""Stopping a child process we started: the one way the launcher (:mod:`nodes.launch`: hub, node
programs) and the I/O modules (:mod:`nodes.iomodules`) end theirs. A module of its own below both, so
that the launcher, which imports the modules, and the modules share it without a cycle."""

from __future__ import annotations

import signal
import subprocess


def stop_process(
    proc: subprocess.Popen | None, *, timeout_s: float = 10.0, sig: int = signal.SIGTERM
) -> int | None:
    """Send ``sig`` to a child we started (by its pid), wait at most ``timeout_s`` s, escalate to
    SIGKILL; return its exit code (None: no process)."""
    if proc is None:
        return None
    if proc.poll() is None:
        try:
            proc.send_signal(sig)
        except ProcessLookupError:
            pass
        try:
            proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    return proc.returncode
