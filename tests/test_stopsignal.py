"""telethermo.stopsignal: SIGTERM stops a polling main loop even when it lands while the main thread holds
the stop event's lock (as it does inside every ``event.wait(timeout)``). Each case is its own process that
signals itself; the same moment with the handler the node programs used before (``event.set()`` inside the
handler) never exits, which is the hang this module removes."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
import threading

import pytest

from telethermo.stopsignal import StopOnSignal

#: the main thread holds the event's internal lock (``Event._cond``, as inside ``Event.wait``) when the
#: signal's Python handler runs: it runs between two bytecodes of the loop below
HOLD_LOCK_AND_SIGNAL = """
    with stop._cond:
        os.kill(os.getpid(), signal.SIGTERM)
        for _ in range(100000):
            pass
    print("stopped" if stop.wait(10) else "not stopped", flush=True)
"""

OURS = """
import os, signal, threading
from telethermo.stopsignal import StopOnSignal
stop = threading.Event()
names = []
with StopOnSignal(stop, on_signal=names.append):
{body}
print(",".join(names), flush=True)
"""

OLD = """
import os, signal, threading
stop = threading.Event()
signal.signal(signal.SIGTERM, lambda *_: stop.set())
if True:
{body}
"""


def run(template: str, timeout_s: float) -> subprocess.CompletedProcess | None:
    """The program with the lock-holding moment; None if it did not end within ``timeout_s``."""
    code = template.format(body=textwrap.indent(textwrap.dedent(HOLD_LOCK_AND_SIGNAL), "    "))
    try:
        return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=timeout_s)
    except subprocess.TimeoutExpired:
        return None


@pytest.mark.slow  # a process of its own
def test_sigterm_while_the_main_thread_holds_the_event_lock_stops_the_loop():
    res = run(OURS, timeout_s=60)
    assert res is not None, "the process did not exit"
    assert res.returncode == 0, res.stderr
    assert res.stdout.split() == ["stopped", "SIGTERM"]


@pytest.mark.slow  # a process of its own
def test_the_handler_that_sets_the_event_itself_hangs_at_that_moment():
    """The control: the same moment with ``event.set()`` in the handler deadlocks (killed after 5 s)."""
    assert run(OLD, timeout_s=5) is None


def test_leaving_the_context_gives_back_the_handlers_and_the_wakeup_fd():
    before = {s: signal.getsignal(s) for s in (signal.SIGTERM, signal.SIGINT)}
    fd_before = signal.set_wakeup_fd(-1)
    signal.set_wakeup_fd(fd_before)
    stop = threading.Event()
    with StopOnSignal(stop) as guard:
        assert signal.getsignal(signal.SIGTERM) is not before[signal.SIGTERM]
        watcher = guard._watcher
    assert {s: signal.getsignal(s) for s in before} == before
    assert signal.set_wakeup_fd(fd_before) == fd_before
    assert watcher is not None and not watcher.is_alive()
    assert not stop.is_set()
