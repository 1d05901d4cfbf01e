"""The one defaults object of the controller: every default number of :class:`CoreParams`, per role and mode.

- :data:`CORE`: the field defaults of a bare ``CoreParams(role=...)`` (core.py reads them from here): a
  plain temperature PI with no flux terms, the flux estimator, the sensor's resistance, the air model.
  No program runs with CORE's gains alone: the nodes and the offline session build their parameters
  with :func:`telethermo.control.params.default_params`, which lays :data:`GAINS` (or
  :data:`RENDER_GAINS` in RENDER mode) over CORE.
- :data:`GAINS`: the tuned gains per role (telepresence); :data:`RENDER_GAINS`, :data:`HOLD_GAINS`,
  :data:`PAPER_GAINS`: the other modes' and the published law's.

Gains were tuned on the simulated rigs (sim/, default 15 × 15 mm TEM, 5 Hz measurement filter) with
the offline session of the guiatni §5.3 scene; see docs/control.md for the tuning and the trade-offs.
Data only (no CoreParams here: core.py imports this module).
"""

from __future__ import annotations

from typing import Any

from telethermo.control.contact import ContactParams, ContactSource
from telethermo.control.types import Role

#: Thermal resistance of the default heat-flux sensor between its two faces, K/W: 0.42 mm thick
#: (guiatni §4.1), 15 × 15 mm, effective conductivity 2.0 W/(m·K) (the design value of the sensor with
#: copper cover plates, sim/data/materials.toml [flux_sensor]): R = e/(k·S) ≈ 0.93 K/W.
DEFAULT_R_SENSOR_K_PER_W = 0.42e-3 / (2.0 * 0.015 * 0.015)

#: CoreParams' field defaults (units in the names; see CoreParams for each field's meaning)
CORE: dict[str, float] = dict(
    period_s=0.01,
    kp_A_per_C=0.4,
    ki_A_per_C_s=2.0,  # plain temperature PI (unit tests, bare CoreParams)
    kQ_A_per_W=0.0,
    kpQ_A_per_W=0.0,
    kiQ_A_per_W_s=0.0,  # no flux feed-forward, no flux loop
    kQ_render_A_per_W=0.0,
    R_sensor_K_per_W=DEFAULT_R_SENSOR_K_PER_W,
    fused_weight=0.5,
    idle_ramp_A_per_s=4.0,
    air_kpQ_A_per_W=0.1,
    air_kiQ_A_per_W_s=1.0,
    G_air_W_per_K=15.0 * 0.015 * 0.015,  # still air, h = 15 W/(m²·K) over 15 × 15 mm
    T_air_C=25.0,
    link_loss_render_s=5.0,  # graceful link loss: render locally this long, s
    osc_guard_C=0.0,  # the slave's oscillation guard off (GAINS turn it on for the slave)
    virtual_finger_b=0.0,  # the probe's virtual finger off (an experiment: docs/control.md)
)

#: role -> parameters at the reference period of 10 ms (telepresence), tuned on probe_touches_al_steel_wood
#: (issue 11: random search then a local search on the transparency headline, each touch's early error
#: against the optimal-current bound, the pre-contact error and the material-cue order; checked on three
#: noise seeds and R_sensor x0.8..x1.2, docs/control.md). The master renders *air* while the probe touches
#: nothing (flux loop towards what air would draw from the finger) and, in contact, tracks T_o with a firm
#: P plus the flux mirror (own flux towards -Q_slave, P and I) and a flux feed-forward; the slave follows
#: T_f softly with a flux feed-forward, and decides contact from its rig's flag (a probe knows when it
#: touches: its force sensor), so that the master learns a release at once.
GAINS: dict[Role, dict[str, Any]] = {
    Role.MASTER: dict(
        kp_A_per_C=1.66,
        ki_A_per_C_s=0.04,
        kQ_A_per_W=0.63,
        kpQ_A_per_W=0.75,
        kiQ_A_per_W_s=0.79,
        air_rendering=True,
        air_kpQ_A_per_W=0.16,
        air_kiQ_A_per_W_s=2.1,
        passive_bound=True,  # the contact target stays where a passive object could take the skin
    ),
    Role.SLAVE: dict(
        kp_A_per_C=0.43,
        ki_A_per_C_s=0.12,
        kQ_A_per_W=0.19,
        kpQ_A_per_W=0.005,
        kiQ_A_per_W_s=0.0,
        contact=ContactParams(source=ContactSource.FLAG),
        osc_guard_C=0.15,  # a ring of the exchange loop in contact quarters kp (control/osc_guard.py)
    ),
}

#: the gains of the paper's law as published (the master tracks the probe's estimate at all times, no air
#: rendering): the previous defaults, kept for the benchmark's comparison
PAPER_GAINS: dict[Role, dict[str, Any]] = {
    Role.MASTER: dict(
        kp_A_per_C=1.0,
        ki_A_per_C_s=0.1,
        kQ_A_per_W=0.0,
        kpQ_A_per_W=0.4,
        kiQ_A_per_W_s=0.0,
        air_rendering=False,
    ),
    Role.SLAVE: dict(kp_A_per_C=0.5, ki_A_per_C_s=0.1, kQ_A_per_W=0.0, kpQ_A_per_W=0.05, kiQ_A_per_W_s=0.0),
}


#: gains of the virtual rendering mode (master alone): a well-damped PI on the surface estimate
RENDER_GAINS: dict[str, float] = dict(kp_A_per_C=0.7, ki_A_per_C_s=1.0, kQ_render_A_per_W=0.0)
#: gains of a plain regulation of the master's pad at a constant target (a virtual scene that renders
#: nothing): the rendering PI, no flux terms (a constant virtual peer draws no flux)
HOLD_GAINS: dict[str, float] = dict(
    kp_A_per_C=0.7, ki_A_per_C_s=1.0, kQ_A_per_W=0.0, kpQ_A_per_W=0.0, kiQ_A_per_W_s=0.0
)
