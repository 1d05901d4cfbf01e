"""Material identification inside the control core: collect each touch's first samples, fit, keep the result.

The slave's core calls :func:`material_step` every cycle with the sample and its contact decision. While
nothing touches, the last ``pre_s`` of samples are kept; from the first contact sample on, ``window_s`` of
samples are collected. The fit (:func:`telethermo.control.material_id.estimate_effusivity`'s stages) then
runs spread over the following cycles so that no control cycle carries the whole fit: the window's signals,
the energy form, the flux form, each of the ``noise_draws`` noise realisations of the confidence
(``units_per_cycle`` of these units a cycle), then the classification: with a calibration
(telethermo.control.material_calib, default the shipped one) its networks' posterior, one layer a cycle,
else the nearest table effusivity. The result (the physics fit's effusivity and standard error of ln b, the
class and its posterior) is published :func:`fit_units` cycles after the window is complete (7 with the
defaults and networks of four layers: 0.07 s at 100 Hz; without an effusivity from either form of the
physics fit, the class alone, without the noise realisations' units) and held until the next touch's fit
completes (a release clears nothing; a fit under way finishes). The staged fit equals the batch one exactly
(material_id.estimate_effusivity, material_calib.classify_vector). Pure: the state is an immutable value.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from dataclasses import dataclass, field, replace
from typing import Any, cast

from telethermo.control.material_id import (
    FORMS,
    EffusivityEstimate,
    FitInput,
    ProbeParams,
    best_form,
    filter_release,
    fit_form,
    fit_input,
    half_integral_matrix,
    noise_deviation,
    noise_draws,
    noise_realisation,
    pre_samples,
    with_noise_spread,
)
from telethermo.control.material_calib import (
    Calibration,
    calibration_vector,
    decide,
    n_units,
    network_input,
    network_unit,
    pooled,
    touch_vector,
)
from telethermo.control import material_physics as mp
from telethermo.control.material_trust import (
    NOVELTY_REASONS,
    abstain_reason,
    envelope_abstention,
    pre_contact,
)
from telethermo.control.material_params import (
    B_SKIN_REF,
    UNITS_PER_CYCLE,
    UNKNOWN_CODE,
    MaterialEstimate,
    MaterialIdParams,
    applies,
    calibrated,
    early_envelope,
    early_samples,
    fit_units,
    fit_work_units,
    late_fit_units,
    late_samples,
)

# re-exported: the node, the benches and the tests import them from here
__all__ = [
    "B_SKIN_REF",
    "UNITS_PER_CYCLE",
    "UNKNOWN_CODE",
    "MaterialEstimate",
    "MaterialIdParams",
    "MaterialState",
    "applies",
    "calibrated",
    "default_calibration",
    "default_classes",
    "default_envelope",
    "early_envelope",
    "early_samples",
    "fit_units",
    "fit_work_units",
    "late_fit_units",
    "late_samples",
    "material_step",
    "prepare",
]
from telethermo.control.material_defaults import default_calibration, default_classes, default_envelope


@dataclass(frozen=True, slots=True)
class FitJob:
    """A touch's fit under way: ``inp`` its window (None: not built yet, from ``rows``), ``fits`` the forms
    fitted so far, ``chosen`` (form, estimate) once both are ((None, None): no effusivity, the calibrated
    class alone), ``deviations`` the noise realisations' so far, ``x`` the networks' input, ``h`` and
    ``probs`` the staged classification's state, ``unit`` its next unit and ``net`` its network ("network"
    the in-box classifier, "envelope" the envelope classifier); ``late``: the refined answer's fit (the late
    window: the physics fit, and the envelope classifier's class when the early answer was its); ``x_early``,
    ``p_early``: the early classifier's input and posterior when the refined answer pools the two."""

    rows: tuple[tuple[float, float], ...]
    n_pre: int
    late: bool = False
    inp: FitInput | None = None
    fits: tuple[tuple[str, EffusivityEstimate | None], ...] = ()
    chosen: tuple[str | None, EffusivityEstimate | None] | None = None
    deviations: tuple[float, ...] = ()
    x: Any = None
    h: Any = None
    probs: tuple[np.ndarray, ...] = ()
    unit: int = 0
    net: str = ""
    x_early: Any = None
    p_early: Any = None


@dataclass(frozen=True, slots=True)
class MaterialState:
    """Collector: ``pre`` the last pre-contact (T_sensor_C, Q_W) samples, ``post`` those since the touch,
    ``done`` the touch's window was collected, ``job`` its fit under way, ``last`` the held result, ``late``
    the refined answer's fit was started."""

    pre: tuple[tuple[float, float], ...] = ()
    post: tuple[tuple[float, float], ...] = ()
    done: bool = False
    last: MaterialEstimate = field(default_factory=MaterialEstimate)
    job: FitJob | None = None
    late: bool = False


def prepare(p: MaterialIdParams, dt_s: float) -> None:
    """Build the fit's cached constants for period ``dt_s`` (the half-integral matrix, the filter's release,
    the noise realisations) now, so that the first touch's fit does not build them inside a control cycle
    (core.init_state calls it)."""
    pr = p.probe
    n_pre = pre_samples(pr, dt_s)
    for n_win in (int(round(pr.window_s / dt_s)), late_samples(p, dt_s)):
        if n_win >= 6:
            half_integral_matrix(n_win, dt_s, 0.5 * dt_s)
            filter_release(n_win, pr.cutoff_Hz, dt_s)
            for k in range(noise_draws(pr)):
                noise_realisation(
                    pr.noise_seed, k, n_pre + n_win, pr.T_sigma_C, pr.Q_sigma_W, pr.cutoff_Hz, dt_s
                )


def material_step(
    p: MaterialIdParams, st: MaterialState, T_sensor_C: float, Q_W: float, contact: bool, dt_s: float
) -> MaterialState:
    """Advance the collector by one sample and the fit under way by ``p.units_per_cycle`` units of work
    (pure). The early
    window's fit starts when its ``window_s`` is collected; while the contact lasts the samples go on being
    collected and the refined answer's fit starts when :func:`late_samples` are (and the early fit is
    done)."""
    job, last = st.job, st.last
    for _ in range(p.units_per_cycle):  # a network layer (the job's input set) ends the cycle
        if job is None:
            break
        job, last = _fit_unit(p, job, last, dt_s)
        if job is not None and job.x is not None:
            break
    n_pre = pre_samples(p.probe, dt_s)
    n_win = early_samples(p, dt_s)
    n_late = late_samples(p, dt_s)
    x = (float(T_sensor_C), float(Q_W))
    if not contact:
        return MaterialState(pre=(st.pre + (x,))[-n_pre:], last=last, job=job)
    if st.done:
        post = st.post if len(st.post) >= n_late else st.post + (x,)
        if st.late or len(post) < n_late or job is not None:
            return MaterialState(pre=st.pre, post=post, done=True, last=last, job=job, late=st.late)
        return MaterialState(
            pre=st.pre,
            post=post,
            done=True,
            last=last,
            late=True,
            job=FitJob(rows=st.pre + post, n_pre=len(st.pre), late=True),
        )
    post = st.post + (x,)
    if len(post) < n_win:
        return MaterialState(pre=st.pre, post=post, last=last, job=job)
    # the window is complete: its fit starts next cycle (a previous touch's fit still under way is dropped)
    return MaterialState(
        pre=st.pre, post=post, done=True, last=last, job=FitJob(rows=st.pre + post, n_pre=len(st.pre))
    )


def _physics(
    p: MaterialIdParams, est: EffusivityEstimate | None, inp: FitInput, cal: mp.PhysicsCalibration
) -> tuple[int, float, str]:
    """(published code, posterior, why abstained) of the physics posterior for fit ``est``."""
    lb = np.log(np.array([b for _, _, b in p.classes], float))
    i, post, why = mp.decide(est, pre_contact(inp)[0], lb, cal)
    return (p.classes[i][0], post, "") if i >= 0 else (UNKNOWN_CODE, post, why)


def _result(
    p: MaterialIdParams,
    est: EffusivityEstimate | None,
    code: int,
    post: float,
    why: str,
    n: int,
    cal: mp.PhysicsCalibration,
    by: str = "physics",
) -> MaterialEstimate:
    """The early answer of touch ``n``; its se_ln_b the calibrated interval's (``cal``)."""
    if est is None:
        return MaterialEstimate(math.nan, math.nan, code, post, n, math.nan, why, code, post, "early", by)
    est = cast(EffusivityEstimate, cal.corrected(est))  # a lab's correction (material_lab), with its interval
    return MaterialEstimate(
        est.b, cal.sigma_ci(est.se_ln_b), code, post, n, est.T_object0_C, why, code, post, "early", by
    )


def _late_result(
    p: MaterialIdParams,
    job: FitJob,
    last: MaterialEstimate,
    answer: tuple[int, float, str] | None = None,
) -> MaterialEstimate:
    """The refined answer replaces the early one's code, posterior and effusivity (the early answer kept);
    ``answer``: the envelope classifier's (code, posterior, why) over the late window, else the physics
    posterior's (the in-box network's class stands)."""
    est = job.chosen[1] if job.chosen is not None else None
    if est is not None:
        est = with_noise_spread(est, list(job.deviations))
    late = cast(mp.PhysicsCalibration, p.late)  # a refined answer's job: p.late is set
    code, post, why = _physics(p, est, cast(FitInput, job.inp), late)
    if answer is not None:
        code, post, why = answer
    elif last.by == "network":  # the network's class in its box stands; b is refined
        code, post, why = last.code, last.posterior, last.abstained
    est = late.corrected(est)  # a lab's correction of the fit (material_lab); decide applies its own
    if est is None:
        return replace(last, code=code, posterior=post, abstained=why, stage="late")
    return replace(
        last,
        effusivity=est.b,
        se_ln_b=late.sigma_ci(est.se_ln_b),
        code=code,
        posterior=post,
        T_object0_C=est.T_object0_C,
        abstained=why,
        stage="late",
    )


@functools.lru_cache(maxsize=8)
def _late_probe(probe: ProbeParams, window_s: float) -> ProbeParams:
    """The probe's settings with the refined answer's window (built once, not in every unit's cycle)."""
    return replace(probe, window_s=window_s)


def _fit_unit(
    p: MaterialIdParams, job: FitJob, last: MaterialEstimate, dt_s: float
) -> tuple[FitJob | None, MaterialEstimate]:
    """One unit of the fit: (the job, or None when finished, and the held result, new when finished)."""
    probe = _late_probe(p.probe, cast(mp.PhysicsCalibration, p.late).window_s) if job.late else p.probe
    n = last.touch + 1
    if job.inp is None:  # the window's signals
        rows = np.array(job.rows, dtype=float).reshape(-1, 2)  # (T_sensor_C, Q_W) per sample
        inp = fit_input(rows[:, 0], rows[:, 1], job.n_pre, dt_s, probe)
        if inp is None:
            return None, (last if job.late else MaterialEstimate(touch=n))
        return replace(job, inp=inp), last
    inp = job.inp
    if job.chosen is None:  # one form per unit, then the better one
        fits = job.fits + tuple(
            (f, fit_form(inp, f, probe)) for f in FORMS[len(job.fits) : len(job.fits) + 1]
        )
        if len(fits) < len(FORMS):
            return replace(job, fits=fits), last
        chosen: tuple[str | None, EffusivityEstimate | None] | None = best_form(list(fits))
        if chosen is None:  # no effusivity; the classifiers need none
            if job.late and not _late_envelope(p, last, dt_s):
                return None, _late_result(p, replace(job, chosen=None), last)
            networks = calibrated(p, dt_s) or early_envelope(p, dt_s)
            if not job.late and (not networks or not p.classes):
                return None, _result(p, None, UNKNOWN_CODE, 0.0, "no_fit", n, p.early)
            chosen = (None, None)
        return replace(job, fits=fits, chosen=chosen), last
    form, est = job.chosen
    k = len(job.deviations)
    if est is not None and k < noise_draws(probe):  # one noise realisation
        dev = noise_deviation(inp, cast(str, form), math.log(est.b), k, probe)  # a fitted form has its name
        return replace(job, deviations=job.deviations + (dev,)), last
    if job.late and not _late_envelope(p, last, dt_s):
        return None, _late_result(p, job, last)
    return _classify_unit(p, job, last, inp, n, dt_s)


def _late_envelope(p: MaterialIdParams, last: MaterialEstimate, dt_s: float) -> bool:
    """Whether the refined answer is the late envelope classifier's (the early one was the envelope's)."""
    return last.by == "envelope" and applies(p.envelope_late, p.late_window_s, dt_s)


def _first_input(
    p: MaterialIdParams, job: FitJob, inp: FitInput, est: EffusivityEstimate | None, dt_s: float
) -> tuple[Any, str]:
    """(the classifying network's input or None, which network: "network" the in-box classifier, "envelope"
    the envelope classifier) of an early window; a late window's is the envelope classifier's."""
    if job.late:  # started only when the late envelope classifier applies
        late = cast(Calibration, p.envelope_late)
        return network_input(late, calibration_vector(late, inp)), "envelope"
    cal = cast(Calibration, p.calibration)  # not None when calibrated
    x = network_input(cal, touch_vector(inp, cal.q_weight_K_per_W)) if calibrated(p, dt_s) else None
    outside = x is None or (p.box is not None and abstain_reason(p.box, inp, est, x) is not None)
    if outside and early_envelope(p, dt_s):
        env = cast(Calibration, p.envelope)
        rows = np.array(job.rows[job.n_pre - inp.n_pre : job.n_pre + env.n_win], dtype=float).reshape(-1, 2)
        own = replace(inp, T=rows[:, 0], Q=rows[:, 1])  # its own window (the fit's may be shorter)
        return network_input(env, calibration_vector(env, own)), "envelope"
    return (None, "") if outside else (x, "network")


def _classify_unit(
    p: MaterialIdParams, job: FitJob, last: MaterialEstimate, inp: FitInput, n: int, dt_s: float
) -> tuple[FitJob | None, MaterialEstimate]:
    """One unit of the classification (one network layer; its first unit also the confidence and the input;
    outside the in-box classifier's box the envelope classifier's, or the physics posterior's without one)."""
    if job.x is None:
        form, est = cast(tuple[str | None, EffusivityEstimate | None], job.chosen)
        est = with_noise_spread(est, list(job.deviations)) if est is not None else None
        x, net = _first_input(p, job, inp, est, dt_s) if p.classes else (None, "")
        if x is None:
            if job.late:
                return None, _late_result(p, job, last)
            if not p.classes:
                return None, MaterialEstimate(touch=n)
            return None, _result(p, est, *_physics(p, est, inp, p.early), n, p.early)
        job = replace(job, x=x, chosen=(form, est), net=net, x_early=_pool_input(p, job, inp, net, last))
    if job.x_early is not None and job.p_early is None:  # the pool's early classifier first, a layer a unit
        env = cast(Calibration, p.envelope_pool)
        h, probs = network_unit(env, job.x_early, job.h, job.probs, job.unit)
        if job.unit + 1 < n_units(env):
            return replace(job, h=h, probs=probs, unit=job.unit + 1), last
        return replace(job, h=None, probs=(), unit=0, p_early=np.mean(probs, axis=0)), last
    cal = cast(Calibration, _net_of(p, job))
    est = cast(tuple[str, EffusivityEstimate | None], job.chosen)[1]  # set by the first unit
    h, probs = network_unit(cal, job.x, job.h, job.probs, job.unit)  # one layer
    if job.unit + 1 < n_units(cal):
        return replace(job, h=h, probs=probs, unit=job.unit + 1), last
    if job.p_early is not None:
        probs = (pooled(job.p_early, np.mean(probs, axis=0), cast(tuple[float, float], cal.pool)),)
    i, post = decide(probs)
    if job.net == "envelope":
        answer = _envelope_answer(p, cal, i, post, est, job.late, inp, job.x)
        if job.late:
            return None, _late_result(p, job, last, answer)
        return None, _result(p, est, *answer, n, p.early, "envelope")
    code = next(c for c, name, _ in p.classes if name == cal.classes[i])
    return None, _result(p, est, code, post, "", n, p.early, "network")


def _pool_input(
    p: MaterialIdParams, job: FitJob, inp: FitInput, net: str, last: MaterialEstimate
) -> np.ndarray | None:
    """The pool's early classifier's input (its first samples of the late window) when a refined envelope
    answer pools the two (``pool`` set), else None; not when the early answer found the touch novel
    (``last.abstained``): a posterior on an input the network does not know is no evidence."""
    late, early = p.envelope_late, p.envelope_pool
    pooling = job.late and net == "envelope" and late is not None and late.pool is not None
    if not pooling or early is None or last.abstained in NOVELTY_REASONS:
        return None
    k = inp.n_pre + early.n_win
    first = replace(inp, T=inp.T[:k], Q=inp.Q[:k])  # the late window holds the early one's samples
    return network_input(early, calibration_vector(early, first))


def _net_of(p: MaterialIdParams, job: FitJob) -> Calibration | None:
    """The network of the job's classification."""
    if job.net == "envelope":
        return p.envelope_late if job.late else p.envelope
    return p.calibration


def _envelope_answer(
    p: MaterialIdParams,
    cal: Calibration,
    i: int,
    post: float,
    est: EffusivityEstimate | None,
    late: bool,
    inp: FitInput,
    x: np.ndarray | None,
) -> tuple[int, float, str]:
    """(code, posterior, why abstained) of the envelope classifier's likeliest class ``i`` at posterior
    ``post``, fit ``est`` (material_trust.envelope_abstention says when it is "unknown")."""
    no = envelope_abstention(cal, post, est, late, inp, x, mp.MIN_POSTERIOR)
    if no is not None:
        return UNKNOWN_CODE, no[1], no[0]
    return next(c for c, name, _ in p.classes if name == cal.classes[i]), post, ""
