"""Default controller parameters per role and period: the configuration the figures are quoted for.

Gains were tuned on the simulated rigs (sim/, default 15 × 15 mm TEM, 5 Hz measurement filter) with
the offline session of the guiatni §5.3 scene; see docs/control.md for the tuning and the trade-offs.
"""
from __future__ import annotations

from typing import Any

from telethermo.control.core import CoreParams
from telethermo.control.types import Mode, Role

#: role -> gains at the reference period of 10 ms (telepresence), from random searches over ~400
#: gain sets on probe_touches_al_steel_wood, ranked on early + late/2 + pre-contact/2 + tracking/2
#: error and checked on three noise seeds (docs/control.md): the master tracks T_o with a firm P and
#: a slow I, plus a proportional flux-mirror term (own flux towards -Q_slave); the slave follows T_f
#: softly. The pair is sensitive: +50 % on the master's kp or kpQ doubles the errors (bench rows).
GAINS: dict[Role, dict[str, float]] = {
    Role.MASTER: dict(kp_A_per_C=1.0, ki_A_per_C_s=0.1, kQ_A_per_W=0.0, kpQ_A_per_W=0.4, kiQ_A_per_W_s=0.0),
    Role.SLAVE: dict(kp_A_per_C=0.5, ki_A_per_C_s=0.1, kQ_A_per_W=0.0, kpQ_A_per_W=0.05, kiQ_A_per_W_s=0.0),
}


#: gains of the virtual rendering mode (master alone): a well-damped PI on the surface estimate
RENDER_GAINS: dict[str, float] = dict(kp_A_per_C=0.7, ki_A_per_C_s=1.0, kQ_render_A_per_W=0.0)
#: gains of a plain regulation of the master's pad at a constant target (a virtual scene that renders
#: nothing): the rendering PI, no flux terms (a constant virtual peer draws no flux)
HOLD_GAINS: dict[str, float] = dict(kp_A_per_C=0.7, ki_A_per_C_s=1.0, kQ_A_per_W=0.0, kpQ_A_per_W=0.0,
                                    kiQ_A_per_W_s=0.0)


def default_params(role: Role, *, period_s: float = 0.01, mode: Mode = Mode.TELEPRESENCE, **overrides: Any) -> CoreParams:
    """The default :class:`CoreParams` of ``role`` at ``period_s`` (keyword overrides win)."""
    role = Role(role)
    gains = RENDER_GAINS if Mode(mode) is Mode.RENDER else GAINS[role]
    kw: dict[str, Any] = dict(role=role, mode=mode, period_s=period_s, **gains)
    kw.update(overrides)
    return CoreParams(**kw)
