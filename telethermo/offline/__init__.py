"""Offline sessions: a scene, both controllers, both simulated rigs and the direct-touch reference in one
process, lockstep; recordings (documented CSV), figures (JSON) and a plot (PNG).

    from telethermo.offline import run_offline_session, compute_figures
"""
from telethermo.offline.figures import compute_figures, contacts_of
from telethermo.offline.recording import (Recording, RecordingBuilder, RecordingError, read_recording_csv,
                                          write_recording_csv)

__all__ = ["compute_figures", "contacts_of", "Recording", "RecordingBuilder", "RecordingError", "read_recording_csv",
           "write_recording_csv", "run_offline_session", "write_session"]


def __getattr__(name):  # the runner imports sim/ and ident lazily
    if name in ("run_offline_session", "write_session", "SessionResult"):
        from telethermo.offline import runner
        return getattr(runner, name)
    raise AttributeError(name)
