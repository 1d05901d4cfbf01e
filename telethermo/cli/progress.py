"""The one progress display of the CLI (``session``, ``identify``, ``calibrate-finger``, ``tune``...).

On a terminal: one line rewritten in place (carriage return). Elsewhere (a pipe, a log file, CI): no
carriage return ever; a plain line each time another ``step_pct`` % is done, and the last one, so that a
log gets ~10 lines, not one per poll. No dependency (tqdm and rich do the same with a 100 kB import).

    bar = Progress("identify: experiment", total=6500, unit="samples")
    bar.update(k)             # as often as you like; rate=... adds "N <unit>/s"
    bar.close()               # ends the line on a terminal
"""

from __future__ import annotations

import sys
import time


def is_tty(stream) -> bool:
    """``stream.isatty()``, False for a stream without one or a closed one."""
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


class Progress:
    """Progress of ``total`` steps of ``unit`` (0: unknown, then a line every ``unknown_every`` steps off a
    terminal). ``stream``: sys.stderr when the display is made; ``tty``: override ``stream.isatty()``
    (tests)."""

    def __init__(
        self,
        label: str,
        total: int,
        *,
        unit: str = "steps",
        stream=None,
        step_pct: float = 10.0,
        tty: bool | None = None,
        unknown_every: int = 1000,
    ) -> None:
        self.label, self.unit = label, unit
        # looked up now, not at import: a default argument would pin whatever sys.stderr was then
        self.stream = stream if stream is not None else sys.stderr
        self.total = max(0, int(total))
        self.step_pct = step_pct
        self.tty = is_tty(self.stream) if tty is None else tty
        self.unknown_every = unknown_every
        self.t0 = time.perf_counter()
        self._next_pct = step_pct
        self._last_k = -1
        self._open = False

    def text(self, k: int, total: int, rate: float | None = None) -> str:
        pct = 100.0 * k / total if total else 0.0
        tail = f", {rate:,.0f} {self.unit}/s" if rate is not None else ""
        return (
            f"{self.label}  {k}/{total or '?'} {self.unit}  ({pct:5.1f} %{tail})  "
            f"{time.perf_counter() - self.t0:.1f} s"
        )

    def update(self, k: int, total: int | None = None, *, rate: float | None = None) -> None:
        total = self.total if not total else int(total)
        if k == self._last_k:
            return
        self._last_k = k
        if self.tty:
            self.stream.write("\r" + self.text(k, total, rate) + "\033[K")
            self.stream.flush()
            self._open = True
            return
        pct = 100.0 * k / total if total else 0.0
        unknown_due = not total and k and k % self.unknown_every == 0
        if (total and (pct >= self._next_pct or k >= total)) or unknown_due:
            self.stream.write(self.text(k, total, rate) + "\n")
            self.stream.flush()
            while total and self._next_pct <= pct:
                self._next_pct += self.step_pct

    def close(self) -> None:
        """End the rewritten line (terminal only); idempotent."""
        if self.tty and self._open:
            self.stream.write("\n")
            self.stream.flush()
            self._open = False
