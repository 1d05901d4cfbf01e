"""A child process we started: reading its start-up line with a deadline, and stopping it. The one way the
launcher (:mod:`nodes.launch`: hub, node programs), the I/O modules (:mod:`nodes.iomodules`) and the
benchmarks wait for and end theirs. A module of its own below both, so that the launcher, which imports the
modules, and the modules share it without a cycle."""

from __future__ import annotations

import signal
import subprocess
import threading


def readline_within(proc: subprocess.Popen, timeout_s: float) -> str:
    """The next line of a child's text ``stdout`` pipe, or "" when none comes within ``timeout_s`` s (or the
    pipe closes): a child that hangs before its ready line cannot hang its parent. The reading thread is a
    daemon; after a timeout the caller stops the child, which ends the read."""
    box: list[str] = []
    out = proc.stdout
    if out is None:
        raise ValueError("readline_within: the process was started without stdout=PIPE")
    reader = threading.Thread(target=lambda: box.append(out.readline()), daemon=True)
    reader.start()
    reader.join(timeout_s)
    return box[0] if box else ""


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
