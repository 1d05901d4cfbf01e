"""Offline sessions: a scene, both controllers, both simulated rigs and the direct-touch reference in one
process, lockstep; recordings (documented CSV), figures (JSON) and a plot (PNG).

    from telethermo.offline import run_offline_session, compute_figures
"""

from telethermo.offline.figures import compute_figures, contacts_of
from telethermo.offline.recording import (
    Recording,
    RecordingBuilder,
    RecordingError,
    read_recording_csv,
    write_recording_csv,
)
from telethermo.offline.runner import SessionResult, run_offline_session, write_session

__all__ = [
    "compute_figures",
    "contacts_of",
    "Recording",
    "RecordingBuilder",
    "RecordingError",
    "read_recording_csv",
    "write_recording_csv",
    "run_offline_session",
    "write_session",
    "SessionResult",
]
