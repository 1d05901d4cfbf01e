"""The session recording, one format for every path (the offline runner, the two node programs, their
merge, the CLI and the benchmarks):

- :mod:`~telethermo.recording.format`: the documented CSV (columns with their units, header, meta), the
  in-memory :class:`Recording`, its reader and writer;
- :mod:`~telethermo.recording.journal`: the one writer, :class:`CsvRecorder` (rows streamed to a journal,
  fsync'd every 0.5 s so a crash loses at most that, renamed into place on close) and the recovery of a
  journal a killed node left;
- :mod:`~telethermo.recording.rows`: the row builders (``side_row``, ``truth_row``, ``ref_row``);
- :mod:`~telethermo.recording.merge`: the two nodes' recordings joined on their SYNC cycle;
- :mod:`~telethermo.recording.result`: the typed results of a run (:class:`RunResult`, the SYNC producer's
  figures; :class:`SessionRun`, a session's ``run`` block) with their JSON form.

It sits below the offline harness and the nodes (docs/architecture.md, "Layers") and imports neither.
"""

from telethermo.recording.format import (
    COLUMNS,
    MAGIC,
    SYNC_CYCLE,
    TEXT_COLUMNS,
    Recording,
    RecordingBuilder,
    RecordingError,
    header_comments,
    node_columns,
    read_recording_csv,
    write_recording_csv,
)
from telethermo.recording.merge import MergeError, merge_recordings
from telethermo.recording.result import RealtimeFigures, RunResult, SessionRun

__all__ = [
    "COLUMNS",
    "MAGIC",
    "TEXT_COLUMNS",
    "Recording",
    "RecordingBuilder",
    "RecordingError",
    "header_comments",
    "node_columns",
    "read_recording_csv",
    "write_recording_csv",
    "SYNC_CYCLE",
    "MergeError",
    "merge_recordings",
    "RealtimeFigures",
    "RunResult",
    "SessionRun",
]
