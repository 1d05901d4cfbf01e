"""When the calibrated classifier may name a material, and when it must say "unknown" (issue 23).

The calibrated network (telethermo.control.material_calib) was trained on reference touches of one box:
objects at 15–35 °C, 2–10 N, 1–20 mm, the shipped probe TEM, the rig's noise, the probe resting at the
finger's natural 33.65 °C (room 25 °C). Outside it the network still answers, and confidently: on touches
drawn across the envelope (bench/material_id_envelope.py) 31 % of its answers at posterior ≥ 0.9 were right.
It sees only changes since the pre-contact mean, so what matters physically is where the probe rested, the
temperature difference between the probe and the object, and the direction of the heat flow.
:func:`abstain_reason` checks what the node measures itself against the calibration's :class:`CalibrationBox`:

- ``probe_rest``: the probe's own temperature before contact (the mean of the pre-contact samples) differs
  from the calibration's rest by more than ``rest_tol_C`` (the rest moves ~0.28 °C per °C of room under the
  slave's default controller; on 1000 in-box touches it stayed within 33.63–33.67 °C);
- ``flux_reversed``: the heat flowed into the probe (mean flux change over the window ≤ 0): the object is
  hotter than the probe, which the calibration covers only up to 35 °C, where the evidence is weak anyway;
- ``no_fit``: the physics fit gave no object temperature (an object at the probe's temperature);
- ``weak_evidence`` / ``object_temperature``: the physics fit's object temperature lies within
  ``min_dT_C`` of the probe, or farther below it than the calibration's coldest object (with ``dT_margin_C``);
- ``far_from_references``: the network's whitened input is longer than any but 0.5 % of in-box touches'.

- ``another_tem``: the probe's module is not the calibration's (``probe_matches`` False: the node's identified
  model differs from the shipped one, telethermo.control.gain_rule.same_module): the network learnt the
  shipped module's touches, and on a swapped module it named 349 of 400 touches with accuracy 0.37
  (tests/control/test_material_tem_swap.py), so the TEM-independent physics posterior answers instead.

It does not see force, thickness or the noise level (none of them measured by the node in the window):
touches outside the box there are still answered, and the envelope bench reports it per stratum.
Pure.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from telethermo.control.material_calib import Calibration, outside_references
from telethermo.control.material_id import EffusivityEstimate, FitInput

#: the envelope classifier's novelty check (:func:`envelope_novelty`): how far beyond its references' range
#: (their standard deviations) an input may lie, the objects' temperatures it learnt (the envelope's, °C) and
#: how far beyond them (°C) the physics fit's object may lie; chosen on development touches inside and outside
#: the envelope (``python -m bench.material_novelty_margin``, docs/material_id.md)
ENVELOPE_NOVELTY_MARGIN = 0.0
ENVELOPE_T_OBJECT_C = (5.0, 50.0)
ENVELOPE_T_MARGIN_C = 10.0


@dataclass(frozen=True, slots=True)
class CalibrationBox:
    """What the calibration knows (defaults: the shipped calibration,
    telethermo/data/material_classifier.npz).

    Attributes:
        rest_C: the probe's pre-contact temperature the references were taken at, °C (the finger's natural
            skin temperature in still air at 25 °C under the slave's default controller,
            bench/material_id_bench.py).
        rest_tol_C: the largest |pre-contact mean − rest_C| still answered, °C.
        T_object_C: the references' object temperatures, °C (lowest, highest).
        min_dT_C: the smallest fitted probe−object difference still answered, °C (below it the touch draws too
            little heat: the near band the issue reports on its own).
        dT_margin_C: allowance for the physics fit's object temperature (median error 1.0 °C, 90 % within
            6.5 °C on in-box touches), °C.
        max_input_norm: the longest whitened network input answered (99.5 % quantile of 1000 in-box touches,
            draw seed 4344, simulator seeds 710000 + i: 21.7).
        probe_matches: the probe's TEM is the calibration's (set False by the node when its identified model
            is another module's: ``another_tem``).
    """

    rest_C: float = 33.65
    rest_tol_C: float = 0.1
    T_object_C: tuple[float, float] = (15.0, 35.0)
    min_dT_C: float = 2.0
    dT_margin_C: float = 2.0
    max_input_norm: float = 21.7
    probe_matches: bool = True


def pre_contact(inp: FitInput) -> tuple[float, float]:
    """(the probe's mean temperature before contact, °C; the mean flux change over the window, W; > 0: heat
    leaving the probe into the object)."""
    n = inp.n_pre
    T0 = float(np.mean(inp.T[:n]))
    return T0, float(np.mean(inp.Q[n:]) - np.mean(inp.Q[:n]))


def abstain_reason(
    box: CalibrationBox, inp: FitInput, est: EffusivityEstimate | None, x: np.ndarray
) -> str | None:
    """Why the touch must not be named (module docstring), or None when it lies inside ``box``.

    ``inp`` the touch's window, ``est`` the physics fit (None: none), ``x`` the network's whitened input."""
    if not box.probe_matches:
        return "another_tem"
    T0, dQ = pre_contact(inp)
    if not abs(T0 - box.rest_C) <= box.rest_tol_C:
        return "probe_rest"
    if not dQ > 0.0:
        return "flux_reversed"
    if est is None or not math.isfinite(est.T_object0_C):
        return "no_fit"
    dT = T0 - est.T_object0_C
    if dT < box.min_dT_C:
        return "weak_evidence"
    if dT > box.rest_C - box.T_object_C[0] + box.dT_margin_C:
        return "object_temperature"
    if not float(np.linalg.norm(x)) <= box.max_input_norm:
        return "far_from_references"
    return None


#: the flux's peak change is looked for over the first FLUX_PEAK_S of the contact, s, and compared with its
#: mean change over a later window, s (:func:`flux_collapse`): the refined answer's and the early one's
FLUX_PEAK_S, FLUX_LATER_S, FLUX_EARLY_LATER_S = 0.15, (0.35, 0.45), (0.20, 0.28)
#: below this peak change of the flux, W, the ratio is the sensor's noise and is not judged
FLUX_COLLAPSE_MIN_PEAK_W = 0.3
#: an answer whose flux falls by more than this factor from its peak to the later window is "unknown"
#: (``flux_collapse``), the refined answer's and the early one's: chosen on the envelope classifier's
#: reference touches and development touches beyond the envelope (``python -m bench.material_flux_collapse``,
#: docs/material_id.md)
FLUX_COLLAPSE_MAX, FLUX_COLLAPSE_MAX_EARLY = 5.0, 2.5


def flux_collapse(inp: FitInput, later_s: tuple[float, float] = FLUX_LATER_S) -> float | None:
    """How far the flux falls after its peak: the largest change from the pre-contact mean over the first
    :data:`FLUX_PEAK_S` of contact over the mean change in ``later_s`` after contact (None: the window is too
    short, or the peak is below :data:`FLUX_COLLAPSE_MIN_PEAK_W`). A slab warms (or cools) to the probe and
    stops drawing heat within its own time constant, ρ·c·e over the contact conductance: about 0.04 s for a
    50 µm metal foil, ten times longer for the thinnest object of the envelope (0.3 mm); a semi-infinite
    object's flux falls as 1/√t. A foil on an insulating back then looks like a touch of EPS to the
    classifier, which learnt nothing thinner than 0.3 mm."""
    n = inp.n_pre
    i_lo, i_hi = (n + int(round(t / inp.dt_s)) for t in later_s)
    if inp.Q.size <= i_hi:
        return None
    q = _flux_change(inp)
    peak = _peak_W(inp, q)
    if not peak >= FLUX_COLLAPSE_MIN_PEAK_W:
        return None
    return peak / max(abs(float(np.mean(q[i_lo:i_hi]))), 1e-3)


def flux_peak_W(inp: FitInput) -> float:
    """The largest change of the flux from its pre-contact mean over the first :data:`FLUX_PEAK_S` of
    contact, W (what :func:`flux_collapse` compares with :data:`FLUX_COLLAPSE_MIN_PEAK_W`)."""
    return _peak_W(inp, _flux_change(inp))


def _flux_change(inp: FitInput) -> np.ndarray:
    """The window's flux less its pre-contact mean, W."""
    return inp.Q - float(np.mean(inp.Q[: inp.n_pre]))


def _peak_W(inp: FitInput, q: np.ndarray) -> float:
    """The largest |q| over the first FLUX_PEAK_S of contact, W."""
    return float(np.max(np.abs(q[inp.n_pre : inp.n_pre + int(round(FLUX_PEAK_S / inp.dt_s))])))


#: the reasons :func:`envelope_novelty` gives: the touch lies outside what the classifier learnt
NOVELTY_REASONS = frozenset({"flux_collapse", "outside_references", "object_temperature"})


def envelope_novelty(
    cal: Calibration,
    x: np.ndarray | None,
    est: EffusivityEstimate | None,
    late: bool,
    inp: FitInput | None = None,
) -> str | None:
    """Why a touch lies outside what the envelope classifier ``cal`` learnt, or None: its network input ``x``
    lies beyond the references' range by more than :data:`ENVELOPE_NOVELTY_MARGIN` in some input
    (``outside_references``), or, for the early answer, the physics fit ``est`` puts the object more than
    :data:`ENVELOPE_T_MARGIN_C` beyond the temperatures it learnt (``object_temperature``): there it would
    guess (a 60–90 °C object was named right in 7 % of early answers on the development touches). Not for
    the refined answer: over 1.2 s the classifier named half of those hot objects right, as many as the
    check would have turned away wrong ones, and the fit's object temperature strays beyond 10 °C on 4 % of
    the touches inside the envelope (thin slabs). For the refined answer, a flux that collapses after its
    peak faster than on any but a few reference touches (:func:`flux_collapse` above
    :data:`FLUX_COLLAPSE_MAX`, window ``inp``) is ``flux_collapse``: an object thinner than the envelope's;
    the early answer, whose window ends at 0.3 s, compares 0.20–0.28 s (above
    :data:`FLUX_COLLAPSE_MAX_EARLY`)."""
    if inp is not None:  # first: the reason a person can act on (the object is too thin)
        later_s, most = (
            (FLUX_LATER_S, FLUX_COLLAPSE_MAX) if late else (FLUX_EARLY_LATER_S, FLUX_COLLAPSE_MAX_EARLY)
        )
        ratio = flux_collapse(inp, later_s)
        if ratio is not None and ratio > most:
            return "flux_collapse"
    if x is not None and outside_references(cal, x, ENVELOPE_NOVELTY_MARGIN):
        return "outside_references"
    lo, hi = ENVELOPE_T_OBJECT_C
    if (
        not late
        and est is not None
        and not lo - ENVELOPE_T_MARGIN_C <= est.T_object0_C <= hi + ENVELOPE_T_MARGIN_C
    ):
        return "object_temperature"
    return None


#: the smallest fitted |probe − object| difference the envelope classifier still names, °C
ENVELOPE_MIN_DT_C = 0.5


def envelope_abstention(
    cal: Calibration,
    post: float,
    est: EffusivityEstimate | None,
    late: bool,
    inp: FitInput,
    x: np.ndarray | None,
    min_posterior: float,
) -> tuple[str, float] | None:
    """(why abstained, the posterior to publish) of the envelope classifier's answer at posterior ``post`` for
    the touch whose window is ``inp`` (the probe resting at its pre-contact mean), or None when it names the
    class: abstained where the touch draws almost no heat, whatever the network says (the early window has
    no physics fit, or the fit puts the object within :data:`ENVELOPE_MIN_DT_C` of the probe), or when the
    posterior is below ``min_posterior`` (material_physics.MIN_POSTERIOR). Not at the physics posterior's
    2 °C: the lumped fit's object temperature is off on thin slabs and behind a contact resistance (measured
    on the envelope bench with the 24 000-touch classifier: abstaining below a fitted 1 °C and without an
    early fit held back 15 % of the early answers outside the 2 °C band, accuracy 0.556 -> 0.494, and still
    left the band's confident answers 73 % right), and the classifier was trained on touches within 2 °C of
    the probe too. The refined answer without a fit over its 1.2 s (a thin slab that has come to the probe's
    temperature) is named: the classifier needs none. A touch outside what the classifier learnt is
    "unknown" too (:func:`envelope_novelty`)."""
    novel = envelope_novelty(cal, x, est, late, inp)
    if novel is not None:
        return novel, post
    if est is None and not late:
        return "no_fit", 0.0
    if est is not None and abs(pre_contact(inp)[0] - est.T_object0_C) < ENVELOPE_MIN_DT_C:
        return "weak_evidence", 0.0
    if post < min_posterior:
        return "low_posterior", post
    return None
