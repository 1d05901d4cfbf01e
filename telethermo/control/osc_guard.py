"""The slave's oscillation guard: detune the probe's kp when the exchange loop rings (issue 22).

Why. In contact both sides track each other over the link: the display follows the probe's object estimate
and its flux, the probe follows the finger estimate. Each side alone is stable (its margins come from its
identified free-pad model, telethermo.control.gain_rule), but the pair closes a loop through the exchange

    T_f -> (delay) -> probe PI -> probe current -> Q_s, T_o -> (delay) -> display PI + flux mirror -> T_f

whose gain the free-pad models do not see: it grows with how much heat the probe's current pushes into
the object and how far the probe's estimate follows its own pad, i.e. with the contact force and on thin
or insulating objects (in the envelope matrix: 7.6 N mean probe force in the oscillating conditions
against 4.9 N, 3.5 mm against 6.5 mm). Measured on the diagnostic conditions: the probe alone tracking a
constant finger estimate through the same touches settles (band RMS 0.01 °C); halving the probe's kp
removes most cycles (ratio 8.5 -> 1.7, 5.2 -> 0.2), while its ki, the display's kp, the display's flux
feed-forward gain, the probe's flux feed-forward and a 0.5 s low-pass on the probe's setpoint each
barely help. But the probe's kp is also what draws the material cue's heat from a metal block, and a
lower kp in every contact costs the base scene its headline (1.252 -> 1.30 °C): the exchange loop's gain
depends on the contact, which the probe learns only by touching.

So the probe measures it: a sustained ring of the finger estimate it receives, in the 0.3-5 Hz band of
the oscillation figure (telethermo.offline.oscillation), in settled contact, means the exchange loop's gain
at that frequency is at least one. By the small-gain argument, cutting the one gain in the loop that moves
it (the probe's kp) by a factor cuts the loop gain there by that factor: on the first ring the guard sets
the probe's kp in contact to :data:`DETUNE` (a quarter) of its own, ki unchanged (a lower kp only adds
phase margin to the probe's own loop, whose free-pad margins the gain rule checked; measured: a quarter
settles more of the diagnostic conditions than a half, none worse), and keeps it for the rest of the
session's contacts (the rig and its contact do not change between touches); in the air the probe keeps its
kp (tracking T_f in the air is what makes it finger-like at the next touch).

Detection: two cascaded first-order high-passes at :data:`BAND_LOW_HZ` (a ramp of the later phase gives
no steady output, unlike one high-pass) and a first-order low-pass at :data:`BAND_HIGH_HZ`; a **ring** is
:data:`LOBES` consecutive half-cycles of that band signal (between sign changes), each with a peak of at
least the threshold, all ending after :data:`SETTLE_S` of contact. A large single transient (the recovery
after a saturated metal touch: a band RMS of 1.1 °C on the base scene) leaves one large lobe after the
settle, a ring two and more: amplitude alone cannot tell the two apart (a 0.1 °C band RMS threshold fired on
the base scene and cost its headline 1.252 -> 1.317 °C). Measured on the §5.3 scene's finger estimate: at
most one lobe with SETTLE_S = 0.7 s (0.5 s gave two on the first wood touch, so the margin is 0.2 s). The
count restarts at every detection and every touch. A lobe counts only if it lasts between :data:`MIN_LOBE_S`
(shorter: the sensor noise's lobes) and :data:`MAX_LOBE_S` (longer: a slow transient, which the two
high-passes answer with two lobes of opposite sign; with sensor noise ×3 the base scene's second lobe, 2.1 s
long, ended after the settle and fired the guard: headline 1.259 -> 1.331 °C at seed 3). Pure functions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

BAND_LOW_HZ = 0.3
BAND_HIGH_HZ = 5.0
LOBES = 2
#: a lobe shorter than this is noise, not a half-cycle of a ring (the rings seen: 0.6-2.7 Hz, half-periods
#: 0.19-0.8 s; the sensor noise's lobes in the band last 0.05-0.1 s), s
MIN_LOBE_S = 0.15
#: a lobe longer than the band's half-period at BAND_LOW_HZ is a slow transient through the high-passes (which
#: turn one recovery into two lobes of opposite sign), not a ring, s
MAX_LOBE_S = 0.5 / BAND_LOW_HZ
SETTLE_S = 0.7
#: the probe's kp in contact after a ring, a share of its own
DETUNE = 0.25


@dataclass(frozen=True, slots=True)
class OscGuardState:
    """The guard's memory: the band-pass filter's states (°C), the current lobe's sign and peak (°C), the
    run of large lobes, the kp scale (1: not detuned) and the number of detections."""

    x_prev: float = math.nan
    h1: float = 0.0
    h2: float = 0.0
    lp: float = 0.0
    sign: int = 0
    peak: float = 0.0
    length_s: float = 0.0
    run: int = 0
    scale: float = 1.0
    detections: int = 0


def guard_step(
    st: OscGuardState, x_C: float, contact_s: float | None, threshold_C: float, dt_s: float
) -> OscGuardState:
    """One step. ``x_C``: the finger estimate received, °C; ``contact_s``: time in the current contact, s
    (None: no contact); ``threshold_C``: the peak of a lobe that counts, °C (0: off).

    >>> import math
    >>> st = OscGuardState()
    >>> for k in range(400):                 # 4 s of contact, a 1 Hz ring of ±0.3 °C on 33 °C
    ...     st = guard_step(st, 33 + 0.3 * math.sin(2 * math.pi * k * 0.01), k * 0.01, 0.1, 0.01)
    >>> st.detections, st.scale
    (1, 0.25)
    >>> st = OscGuardState()
    >>> for k in range(400):                 # a 3 °C drop that settles (a touch's recovery) is no ring
    ...     st = guard_step(st, 30 + 3 * math.exp(-k * 0.01 / 0.4), k * 0.01, 0.1, 0.01)
    >>> st.detections
    0
    """
    if threshold_C <= 0.0 or not math.isfinite(x_C):
        return st
    a = 1.0 / (1.0 + 2.0 * math.pi * BAND_LOW_HZ * dt_s)  # backward-Euler high-pass coefficient
    b = dt_s / (dt_s + 1.0 / (2.0 * math.pi * BAND_HIGH_HZ))  # low-pass coefficient
    if contact_s is None or not math.isfinite(st.x_prev):
        # out of contact (or first sample): the filters rest on the signal, nothing counts
        return OscGuardState(x_C, scale=st.scale, detections=st.detections)
    h1 = a * (st.h1 + x_C - st.x_prev)
    h2 = a * (st.h2 + h1 - st.h1)
    lp = st.lp + b * (h2 - st.lp)
    sign, peak, run, length = st.sign, max(st.peak, abs(lp)), st.run, st.length_s + dt_s
    s_now = 1 if lp > 0 else -1
    if s_now != sign:  # a lobe ended: count it if it was large, long and in settled contact
        long_enough = MIN_LOBE_S <= st.length_s <= MAX_LOBE_S
        big = contact_s >= SETTLE_S and st.peak >= threshold_C and long_enough
        run = run + 1 if big else 0
        sign, peak, length = s_now, abs(lp), 0.0
    scale, det = st.scale, st.detections
    if run >= LOBES and scale > DETUNE:
        scale, det, run = DETUNE, det + 1, 0
    return OscGuardState(x_C, h1, h2, lp, sign, peak, length, run, scale, det)
