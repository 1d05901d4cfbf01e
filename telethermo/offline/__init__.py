"""Offline sessions: a scene, both controllers, both simulated rigs and the direct-touch reference in one
process, lockstep; their figures (JSON) and a plot (PNG). The recording itself (the documented CSV) is
:mod:`telethermo.recording`.

    from telethermo.offline import run_offline_session, compute_figures
"""

from telethermo.offline.figures import compute_figures, contacts_of
from telethermo.offline.runner import SessionResult, run_offline_session, write_session

__all__ = [
    "compute_figures",
    "contacts_of",
    "run_offline_session",
    "write_session",
    "SessionResult",
]
