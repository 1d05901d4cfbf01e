"""PI + heat-flux feed-forward (guiatni eq. 33) with anti-windup that includes the feed-forward.

    u = kp·e + I + u_ff,     I_k = I_{k-1} + ki·e·dt   (then clamped, see below)

Anti-windup (integrator clamping that accounts for the feed-forward): after the integration step
the integrator is clamped to [u_min - kp·e - u_ff, u_max - kp·e - u_ff] ∩ [u_min, u_max], so the
unsaturated sum never needs the output clamp while the integrator can still act, and a large
feed-forward does not let the integrator wind up behind it. The output is finally clamped to
[u_min, u_max].

Bumpless switching (:func:`bumpless`): when the setpoint source, the gains or the feed-forward
change, the integrator is re-seeded so that the output is continuous.

Everything here is pure: :func:`pi_step` returns a new :class:`PIState` and the components.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class PIGains:
    """Gains of the PI + feed-forward law.

    Attributes:
        kp_A_per_C: proportional gain, A/°C.
        ki_A_per_C_s: integral gain, A/(°C·s).
    """

    kp_A_per_C: float
    ki_A_per_C_s: float

    def __post_init__(self) -> None:
        for name in ("kp_A_per_C", "ki_A_per_C_s"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise ValueError(f"PIGains.{name}: expected a finite number >= 0, got {v!r}")


@dataclass(frozen=True, slots=True)
class FluxPIGains:
    """Gains of the heat-flux tracking loop that shares the PI's integrator (its error is in W).

    Attributes:
        kp_A_per_W: proportional gain, A/W.
        ki_A_per_W_s: integral gain, A/(W·s).
    """

    kp_A_per_W: float
    ki_A_per_W_s: float

    def __post_init__(self) -> None:
        for name in ("kp_A_per_W", "ki_A_per_W_s"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise ValueError(f"FluxPIGains.{name}: expected a finite number >= 0, got {v!r}")


@dataclass(frozen=True, slots=True)
class PIState:
    """Integrator of the PI, A (the integral term itself, so gain changes are bumpless)."""

    integral_A: float = 0.0


@dataclass(frozen=True, slots=True)
class PIComponents:
    """Introspection of one PI step (simple-pid's ``components``), all in A.

    Attributes:
        p_A: proportional term kp·e. i_A: integral term after the step. ff_A: feed-forward term.
        u_unsat_A: p + i + ff before the output clamp. u_A: the clamped output.
        saturated: the output clamp acted.
    """

    p_A: float
    i_A: float
    ff_A: float
    u_unsat_A: float
    u_A: float
    saturated: bool


def _clip(x: float, lo: float, hi: float) -> float:
    return lo if x < lo else hi if x > hi else x


def pi_step(
    gains: PIGains,
    state: PIState,
    error_C: float,
    ff_A: float,
    dt_s: float,
    u_min_A: float,
    u_max_A: float,
    *,
    flux_error_W: float = 0.0,
    flux_gains: FluxPIGains | None = None,
) -> tuple[float, PIState, PIComponents]:
    """One PI + feed-forward step. Returns ``(u_A, new_state, components)``.

    ``flux_gains`` (:class:`FluxPIGains`, A/W and A/(W·s)) add a heat-flux tracking loop on
    ``flux_error_W`` sharing the integrator and the anti-windup.
    Non-finite errors or ``ff_A`` are treated as 0 (the safety envelope trips on their causes);
    the integrator then holds. ``u_min_A < u_max_A`` is required.

    Unsaturated: p = 2 A/°C · 1 °C, the integrator gains 0.5 · 1 · 0.1 A, the feed-forward adds 0.5 A:

    >>> u, st, c = pi_step(PIGains(2.0, 0.5), PIState(), 1.0, 0.5, 0.1, -3.0, 3.0)
    >>> u, st.integral_A, c.saturated
    (2.55, 0.05, False)

    Anti-windup with the feed-forward: p + ff = 4.5 A exceed the 3 A limit, so the integrator is clamped
    to 3 - 4.5 = -1.5 A and the output sits at the limit without the output clamp acting:

    >>> u, st, c = pi_step(PIGains(2.0, 0.5), PIState(), 2.0, 0.5, 0.1, -3.0, 3.0)
    >>> u, st.integral_A, c.saturated
    (3.0, -1.5, False)
    """
    if not math.isfinite(error_C):
        error_C = 0.0
    if not math.isfinite(ff_A):
        ff_A = 0.0
    p = gains.kp_A_per_C * error_C
    di = gains.ki_A_per_C_s * error_C
    if flux_gains is not None and math.isfinite(flux_error_W):
        p += flux_gains.kp_A_per_W * flux_error_W
        di += flux_gains.ki_A_per_W_s * flux_error_W
    i = state.integral_A + di * dt_s
    # anti-windup including the feed-forward
    i = _clip(i, u_min_A - p - ff_A, u_max_A - p - ff_A)
    i = _clip(i, u_min_A, u_max_A)
    u_unsat = p + i + ff_A
    u = _clip(u_unsat, u_min_A, u_max_A)
    return u, PIState(i), PIComponents(p, i, ff_A, u_unsat, u, u != u_unsat)


def bumpless(
    gains: PIGains,
    u_prev_A: float,
    error_C: float,
    ff_A: float,
    u_min_A: float,
    u_max_A: float,
    *,
    flux_error_W: float = 0.0,
    flux_gains: FluxPIGains | None = None,
) -> PIState:
    """Integrator that makes ``kp·error + I + ff`` equal the previous output ``u_prev_A`` (clamped).

    New gains, same output: the next step (dt 0, so the integrator does not move) gives 1.2 A again.

    >>> st = bumpless(PIGains(4.0, 0.5), 1.2, 0.1, 0.3, -3.0, 3.0)
    >>> round(st.integral_A, 12), round(pi_step(PIGains(4.0, 0.5), st, 0.1, 0.3, 0.0, -3.0, 3.0)[0], 12)
    (0.5, 1.2)
    """
    if not math.isfinite(u_prev_A):
        u_prev_A = 0.0
    e = error_C if math.isfinite(error_C) else 0.0
    f = ff_A if math.isfinite(ff_A) else 0.0
    p = gains.kp_A_per_C * e
    if flux_gains is not None and math.isfinite(flux_error_W):
        p += flux_gains.kp_A_per_W * flux_error_W
    i = u_prev_A - p - f
    return PIState(_clip(i, u_min_A, u_max_A))
