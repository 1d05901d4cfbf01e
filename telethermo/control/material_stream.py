"""Material identification inside the control core: collect each touch's first samples, fit, keep the result.

The slave's core calls :func:`material_step` every cycle with the sample and its contact decision. While
nothing touches, the last ``pre_s`` of samples are kept; from the first contact sample on, ``window_s`` of
samples are collected. The fit (:func:`telethermo.control.material_id.estimate_effusivity`'s stages) then
runs spread over the following cycles, one unit of work per cycle so that no control cycle carries the
whole fit: the window's signals, the energy form, the flux form, each of the ``noise_draws`` noise
realisations of the confidence, then the classification: with a calibration
(telethermo.control.material_calib, default the shipped one) its networks' posterior, else the nearest table
effusivity. The networks run one layer per cycle. The result (the physics fit's effusivity and standard error
of ln b, the class and its posterior) is published :func:`fit_units` cycles after the window is complete (15
with the defaults and networks of four layers: 0.15 s at 100 Hz; without an effusivity from either form of the
physics fit, the class alone, without the noise realisations' cycles) and held until the next touch's fit
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
    ENVELOPE_EARLY,
    ENVELOPE_LATE,
    ENVELOPE_POOL,
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
    CalibrationBox,
    abstain_reason,
    envelope_abstention,
    pre_contact,
)
from telethermo.control.material_defaults import default_calibration, default_classes, default_envelope

#: the finger reference of the rendering table's β = b/b_skin for the simulator's materials, W·s^½/(m²·K)
#: (sim/data/materials.toml [materials.skin]: √(0.21 · 1200 · 3590); telethermo/data/render_materials.toml)
B_SKIN_REF = 951.15
#: the published code of an abstention ("unknown"): the touch lies outside what the classifier was
#: calibrated on, or its evidence is weak; the effusivity and object temperature the physics fit measured
#: are still published
UNKNOWN_CODE = 255


@dataclass(frozen=True, slots=True)
class MaterialEstimate:
    """The last identified material.

    Attributes:
        effusivity: W·s^½/(m²·K) (NaN: no estimate: too few or non-finite samples, no information).
        se_ln_b: standard error of ln b (≈ relative error of the effusivity; NaN without an estimate).
        code: the material's position in the rendering table (1-based, the OD's material code), 0: none.
        posterior: the class's posterior probability (0 without an estimate).
        touch: how many touches have been evaluated (counts also those without an estimate).
        T_object0_C: the object's initial temperature the same fit gives, °C (NaN without an estimate).
        abstained: why the answer is "unknown" (code :data:`UNKNOWN_CODE`; telethermo.control.material_physics
            .decide), "" when it named a material.
        early_code, early_posterior: the first answer (0.3 s window, the envelope classifier's 0.34 s; the
            network in its box, else the physics posterior), kept when the refined one (``stage`` "late", the
            physics fit over 1.2 s) replaces ``code`` and ``posterior``.
        stage: "early" or "late" (the answer in ``code``), "" without an answer.
        by: "network" (the calibrated classifier in its box: the refined answer keeps its class and posterior,
            the late fit refines the effusivity only) or "physics" (telethermo.control.material_physics).
    """

    effusivity: float = math.nan
    se_ln_b: float = math.nan
    code: int = 0
    posterior: float = 0.0
    touch: int = 0
    T_object0_C: float = math.nan
    abstained: str = ""
    early_code: int = 0
    early_posterior: float = 0.0
    stage: str = ""
    by: str = ""

    @property
    def beta(self) -> float:
        """Relative effusivity b/b_skin (the rendering table's and the OD's material_beta scale)."""
        return self.effusivity / B_SKIN_REF


@dataclass(frozen=True, slots=True)
class MaterialIdParams:
    """Settings of the identification.

    Attributes:
        probe: the estimator's probe model (:class:`ProbeParams`).
        classes: (code, name, effusivity) of the rendering table's entries with an effusivity.
        calibration: the calibrated classifier (default: the shipped file,
            telethermo/data/material_classifier.npz, loaded once); None: the nearest table effusivity of the
            physics fit. Used only when its period and window are the core's (:func:`calibrated`); its
            materials must be among ``classes``.
        box: what the calibration was measured on; a touch outside it is named by the physics posterior
            (telethermo.control.material_physics) instead of the network; None: the network always names it.
        early, late: the physics posterior's calibration of the early (0.3 s) and refined answer (1.2 s of
            contact; ``late`` None: no refined answer).
        envelope, envelope_late: the envelope classifiers of the early and the refined answer (default: the
            shipped files, telethermo/data/material_envelope_*.npz; telethermo.offline.material_envelope_refs
            says what they were trained on): they name a touch outside ``box`` in place of the physics
            posterior, where they apply (:func:`applies`); None: the physics posterior. ``envelope_pool``:
            the early classifier (0.3 s) the refined answer pools with (its pool was fitted with it).
    """

    probe: ProbeParams = field(default_factory=ProbeParams)
    classes: tuple[tuple[int, str, float], ...] = field(default_factory=lambda: default_classes())
    calibration: Calibration | None = field(default_factory=lambda: default_calibration())
    box: CalibrationBox | None = field(default_factory=CalibrationBox)
    early: mp.PhysicsCalibration = mp.EARLY
    late: mp.PhysicsCalibration | None = mp.LATE
    envelope: Calibration | None = field(default_factory=lambda: default_envelope(ENVELOPE_EARLY))
    envelope_late: Calibration | None = field(default_factory=lambda: default_envelope(ENVELOPE_LATE))
    envelope_pool: Calibration | None = field(default_factory=lambda: default_envelope(ENVELOPE_POOL))

    @property
    def late_window_s(self) -> float:
        """The refined answer's window, s (0: none)."""
        return self.late.window_s if self.late is not None else 0.0

    def __post_init__(self) -> None:
        if self.calibration is not None:
            names = {n for _, n, _ in self.classes}
            missing = [c for c in self.calibration.classes if c not in names]
            if missing:
                raise ValueError(
                    f"material classifier names {missing} that the rendering table has no effusivity for"
                )


def applies(cal: Calibration | None, window_s: float, dt_s: float) -> bool:
    """Whether classifier ``cal`` was measured at period ``dt_s`` over a window of ``window_s``."""
    n = int(round(window_s / dt_s))
    return cal is not None and abs(cal.dt_s - dt_s) <= 1e-9 and window_s > 0.0 and cal.n_win == n


def calibrated(p: MaterialIdParams, dt_s: float) -> bool:
    """Whether the calibration applies at period ``dt_s`` (measured with the same period and window)."""
    return applies(p.calibration, p.probe.window_s, dt_s)


def early_samples(p: MaterialIdParams, dt_s: float) -> int:
    """Samples after the touch the early answer waits for: the physics fit's window, or the early envelope
    classifier's when longer (0.34 s against 0.3 s: docs/material_id.md), not beyond the refined one's."""
    n, env, n_late = int(round(p.probe.window_s / dt_s)), p.envelope, late_samples(p, dt_s)
    if env is None or abs(env.dt_s - dt_s) > 1e-9 or not n <= env.n_win <= max(n_late, n):
        return n
    return env.n_win


def early_envelope(p: MaterialIdParams, dt_s: float) -> bool:
    """Whether the early envelope classifier applies at period ``dt_s`` (its window is the early answer's)."""
    return applies(p.envelope, early_samples(p, dt_s) * dt_s, dt_s)


def fit_units(p: MaterialIdParams, dt_s: float) -> int:
    """Cycles from the window's completion to the published result (one unit of work each: the window's
    signals, the energy form, the flux form, each noise realisation, then the classification: one layer of the
    calibrated networks per cycle, or the nearest effusivity in one)."""
    cal = cast(Calibration, p.calibration)  # not None when calibrated
    return 1 + len(FORMS) + noise_draws(p.probe) + (n_units(cal) if calibrated(p, dt_s) else 1)


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


def late_samples(p: MaterialIdParams, dt_s: float) -> int:
    """Samples after the touch the refined answer's fit uses (0: no refined answer)."""
    if p.late is None:
        return 0
    n = int(round(p.late.window_s / dt_s))
    return n if n > int(round(p.probe.window_s / dt_s)) else 0


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
    """Advance the collector by one sample and the fit under way by one unit of work (pure). The early
    window's fit starts when its ``window_s`` is collected; while the contact lasts the samples go on being
    collected and the refined answer's fit starts when :func:`late_samples` are (and the early fit is
    done)."""
    job, last = st.job, st.last
    if job is not None:
        job, last = _fit_unit(p, job, last, dt_s)
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
