"""The parameters a role runs with: :func:`default_params` lays the role's tuned gains
(:data:`telethermo.control.defaults.GAINS`, or ``RENDER_GAINS`` in RENDER mode) over CoreParams'
field defaults (``defaults.CORE``). The nodes, the offline session and the tuner build their
:class:`CoreParams` here.
"""

from __future__ import annotations

from typing import Any

from telethermo.control.core import CoreParams
from telethermo.control.defaults import GAINS, RENDER_GAINS
from telethermo.control.safety_limits import probe_limits
from telethermo.control.types import Mode, Role


def default_params(
    role: Role, *, period_s: float = 0.01, mode: Mode = Mode.TELEPRESENCE, **overrides: Any
) -> CoreParams:
    """The default :class:`CoreParams` of ``role`` at ``period_s`` (keyword overrides win)."""
    role = Role(role)
    gains = RENDER_GAINS if Mode(mode) is Mode.RENDER else GAINS[role]
    kw: dict[str, Any] = dict(role=role, mode=mode, period_s=period_s, **gains)
    if role is Role.SLAVE:
        kw["safety"] = probe_limits()  # the probe's envelope protects its hardware, not skin (DESIGN.md §6)
    kw.update(overrides)
    return CoreParams(**kw)
