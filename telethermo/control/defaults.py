"""Default controller parameters per role and period: the configuration the figures are quoted for.

Gains were tuned on the simulated rigs (sim/, default 15 × 15 mm TEM, 5 Hz measurement filter) with
the offline session of the guiatni §5.3 scene; see docs/control.md for the tuning and the trade-offs.
"""
from __future__ import annotations

from typing import Any

from telethermo.control.core import CoreParams
from telethermo.control.types import Mode, Role

#: role -> (kp A/°C, ki A/(°C·s), kQ A/W) at the reference period of 10 ms
GAINS: dict[Role, tuple[float, float, float]] = {
    Role.MASTER: (0.4, 2.0, 0.0),
    Role.SLAVE: (0.4, 2.0, 0.0),
}


def default_params(role: Role, *, period_s: float = 0.01, mode: Mode = Mode.TELEPRESENCE, **overrides: Any) -> CoreParams:
    """The default :class:`CoreParams` of ``role`` at ``period_s`` (keyword overrides win)."""
    kp, ki, kq = GAINS[Role(role)]
    kw: dict[str, Any] = dict(role=Role(role), mode=mode, period_s=period_s, kp_A_per_C=kp, ki_A_per_C_s=ki,
                              kQ_A_per_W=kq)
    kw.update(overrides)
    return CoreParams(**kw)
