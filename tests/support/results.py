"""The JSON results of the stress and conformance tests, written when pytest is asked to
(``--write-results DIR``; ``python -m bench.stress`` and ``python -m bench.conformance_bench`` ask).

A test adds one entry per case or check to a named group (``stress``, ``conformance``) with the function
that turns the group's entries into the result document; at the end of the session each group that got
entries is written to ``DIR/<group>.json`` with its provenance (machine, versions, date, commit), the
same shape the benchmarks write.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Callable

from telethermo.atomic import write_json_atomic
from telethermo.provenance import provenance

Summary = Callable[[list[dict[str, Any]], float], dict[str, Any]]
"""(entries in the order run, wall time of the session so far in s) -> the result document."""


class ResultsWriter:
    """Collects entries per group during a session; :meth:`write` writes them (when a folder was given)."""

    def __init__(self, out_dir: str | Path | None) -> None:
        self.out_dir = Path(out_dir) if out_dir else None
        self._groups: dict[str, tuple[Summary, list[dict[str, Any]]]] = {}
        self._t0 = time.perf_counter()

    def add(self, group: str, entry: dict[str, Any], summary: Summary) -> None:
        """Record ``entry`` in ``group``; ``summary`` builds the group's document at the end."""
        self._groups.setdefault(group, (summary, []))[1].append(entry)

    def document(self, group: str) -> dict[str, Any]:
        """The result document of ``group`` as it would be written (without provenance)."""
        summary, entries = self._groups[group]
        return summary(entries, time.perf_counter() - self._t0)

    def write(self) -> list[Path]:
        """Write every group to ``<out_dir>/<group>.json``; nothing when no folder was given."""
        if self.out_dir is None:
            return []
        written = []
        for group in self._groups:
            data = dict(self.document(group))
            data["provenance"] = provenance()
            written.append(write_json_atomic(self.out_dir / f"{group}.json", data))
        return written
