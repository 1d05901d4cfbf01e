"""SIGINT/SIGTERM that stop a process's main loop, with no lock taken inside a signal handler.

A Python signal handler runs in the main thread between two bytecodes, wherever that thread is. A handler
that calls ``threading.Event.set()`` takes the event's internal lock; if the main thread held that lock at
the moment (it does, briefly, on every ``event.wait(timeout)`` of a polling loop), the handler waits for
a lock its own thread holds and the process never exits (the same trap as CPython gh-126434 for
``multiprocessing.Event``). Seen here once in a full test run: a ``telethermo-iomodule`` that did not exit
within 20 s of SIGTERM; tests/test_stopsignal.py makes that moment on purpose.

:class:`StopOnSignal` installs a handler that does nothing and lets the interpreter's C-level handler
write the signal number to a pipe (:func:`signal.set_wakeup_fd`); a watcher thread reads the pipe and sets
the event from an ordinary thread, where waiting for the lock is harmless. Use it from the main thread::

    with StopOnSignal(stop_event, on_signal=lambda name: ...):
        while not stop_event.wait(0.5):
            ...
"""

from __future__ import annotations

import os
import signal
import threading
from typing import Callable

#: the signals that stop a node or module program
STOP_SIGNALS = (signal.SIGTERM, signal.SIGINT)


def _ignore(signum: int, frame: object) -> None:
    """The Python-level handler: nothing (the wakeup pipe carries the signal to the watcher)."""


class StopOnSignal:
    """Set ``event`` (and call ``on_signal`` with the signal's name, from the watcher thread) when one of
    ``signals`` arrives, for as long as the context is entered. Main thread only."""

    def __init__(
        self,
        event: threading.Event,
        *,
        on_signal: Callable[[str], None] | None = None,
        signals: tuple[signal.Signals, ...] = STOP_SIGNALS,
    ) -> None:
        self.event = event
        self.on_signal = on_signal
        self.signals = tuple(signals)
        self._old_handlers: dict[int, object] = {}
        self._old_fd = -1
        self._pipe: tuple[int, int] | None = None
        self._watcher: threading.Thread | None = None

    def __enter__(self) -> "StopOnSignal":
        r, w = os.pipe()
        os.set_blocking(w, False)  # the C handler never blocks; a full pipe drops bytes, never a signal
        self._pipe = (r, w)
        self._old_fd = signal.set_wakeup_fd(w, warn_on_full_buffer=False)
        for sig in self.signals:
            self._old_handlers[sig] = signal.signal(sig, _ignore)
        self._watcher = threading.Thread(target=self._watch, args=(r,), name="stop-signal", daemon=True)
        self._watcher.start()
        return self

    def __exit__(self, *exc: object) -> None:
        for sig, old in self._old_handlers.items():
            signal.signal(sig, old)  # type: ignore[arg-type]
        self._old_handlers.clear()
        signal.set_wakeup_fd(self._old_fd)
        if self._pipe is not None:
            os.close(self._pipe[1])  # the watcher reads end-of-file and returns
            if self._watcher is not None:
                self._watcher.join(1.0)
            os.close(self._pipe[0])
            self._pipe = None

    def _watch(self, r: int) -> None:
        wanted = {int(s) for s in self.signals}
        while True:
            try:
                data = os.read(r, 64)
            except OSError:
                return
            if not data:
                return
            for signum in data:
                if signum not in wanted:
                    continue
                if self.on_signal is not None:
                    self.on_signal(signal.Signals(signum).name)
                self.event.set()
