"""One timer thread per device: named deadlines (heartbeat producer, consumer timeouts, EMCY inhibit).

Jobs run in the scheduler's thread, outside its lock; an exception in a job is logged and counted,
never kills the thread. Deadlines are on an injectable monotonic clock (s).
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Callable

logger = logging.getLogger(__name__)


class Scheduler:
    """Named one-shot deadlines; ``set`` again to re-arm, ``cancel`` to drop."""

    def __init__(self, name: str, clock: Callable[[], float] = time.monotonic):
        self.clock = clock
        self.errors = 0
        self._jobs: dict[str, tuple[float, Callable[[], None]]] = {}
        self._cond = threading.Condition()
        self._stopped = False
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def set(self, key: str, at: float, fn: Callable[[], None]) -> None:
        """Run ``fn`` at clock time ``at`` (s), replacing any job with the same key."""
        with self._cond:
            self._jobs[key] = (at, fn)
            self._cond.notify()

    def cancel(self, key: str) -> None:
        with self._cond:
            self._jobs.pop(key, None)

    def cancel_prefix(self, prefix: str) -> None:
        with self._cond:
            for k in [k for k in self._jobs if k.startswith(prefix)]:
                del self._jobs[k]

    def deadline(self, key: str) -> float | None:
        with self._cond:
            job = self._jobs.get(key)
            return None if job is None else job[0]

    def stop(self, timeout: float = 2.0) -> None:
        with self._cond:
            self._stopped = True
            self._jobs.clear()
            self._cond.notify()
        if threading.current_thread() is not self._thread:
            self._thread.join(timeout)

    def _run(self) -> None:
        while True:
            with self._cond:
                while True:
                    if self._stopped:
                        return
                    now = self.clock()
                    due = [(k, fn) for k, (at, fn) in self._jobs.items() if at <= now]
                    if due:
                        for k, _ in due:
                            del self._jobs[k]
                        break
                    nxt = min((at for at, _ in self._jobs.values()), default=None)
                    self._cond.wait(None if nxt is None else max(0.0, nxt - now))
            for key, fn in due:
                try:
                    fn()
                except Exception:  # a job must never kill the timer thread
                    self.errors += 1
                    logger.exception("scheduled job %s failed", key)
