"""Material identification on the slave: the touched object's effusivity from the probe's own contact
transient.

What the slave measures (telethermo.rig.RigSample): the thermocouple at the flux sensor's mid-plane
``T_sensor_C`` and the thickness-mean flux ``Q_W`` through the sensor (> 0 out of the pad), both after the
rig's 2nd-order low-pass filter, plus the rig's contact flag. Between the thermocouple and the object lie
the upper half of the sensor (resistance R_half = R_sensor/2, heat capacity C_half) and the contact
resistance R_c (unknown: it depends on the force and the surfaces).

Model over the first ``window_s`` after the touch, in energy form (smooth, where the flux itself is
singular at the touch): a semi-infinite object at T_o0 whose surface follows T_os(t) has taken in

    E(t) = b·A·I½[T_os − T_o0](t),   I½[f](t) = 1/√π ∫ f(σ)/√(t − σ) dσ   (a step ΔT: E = 2·b·A·ΔT·√(t/π)),

with T_os = T_top − R_c·q. From the measured signals: E = ∫Q dt − C_half·ΔT̄_upper (the heat the sensor's
upper half keeps), T_top = T_sensor − R_half·(Q − ½·C_half·dT_sensor/dt) (the upper half's mean flux).
Hence, with H the touch's step,

    E = b·A·I½[T_top·H] − (b·T_o0)·A·I½[H] − (b·R_c)·A·I½[q·H],

linear in (b, b·T_o0, b·R_c): least squares, b·R_c kept ≥ 0. The same relation differentiated, the flux
form T_top = T_o0 + (1/b)·I½[q_top]/A + R_c·q_top with q_top = dE/dt, is linear in (T_o0, 1/b, R_c) and
weighs the early samples more; both are fitted and the one with the smaller standard error of ln b kept
(the energy form wins on insulators, the flux form on metals behind a contact resistance).

The rig's filter is linear and time-invariant, as are I½ and ∫, so the relation holds for the filtered
signals once the filter's memory of the pre-contact state is removed: the filter's response to the touch's
step, ``s(k)`` (1 at the touch, → 0), times the pre-contact means (:func:`filter_release`; the rig's
documented 2nd-order Butterworth, ``cutoff_Hz`` = 0 for an unfiltered rig).

Identifiability: the probe's own temperature history is what separates b from T_o0. For two ideal
semi-infinite bodies the face temperature is constant (eq. 1) and only b·(T_c − T_o0) is seen; the probe's
face moves because the sensor is thin and the controller drives it, but for insulators it hardly moves,
so a weak prior on the object's temperature (``prior_T_object_C``, weight ``prior_weight``) keeps the fit
defined; for metals the object's surface hardly moves and b hides behind R_half + R_c (a few % of the
temperature drop): the standard error says so.

Confidence: the standard error of ln b combines the residuals' (σ²·(XᵀX)⁻¹, σ² inflated by the residuals'
lag-1 autocorrelation (1 + ρ)/(1 − ρ): the filter makes neighbouring residuals correlated) with the spread
of ln b when the rig's documented noise is drawn again (``noise_draws`` seeded realisations through the
same filter): the noise of the early samples enters every later one through the integrals, which the
residuals do not show. The model's own bias (a few % on clean touches, more on thin slabs) is not in it.

Classification (:func:`classify`): nearest table effusivity in ln b; the posterior of each class under a
Gaussian in ln b with the estimate's standard error widened by a model floor ``floor_ln``, and the margin
to the second nearest, in units of that σ.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import cast

import numpy as np
from numpy.typing import ArrayLike

from telethermo.inputfile import Section, load_toml
from telethermo.control.rendering import DEFAULT_RENDER_TABLE
from telethermo.control.small_lstsq import NormalEquations


@dataclass(frozen=True, slots=True)
class ProbeParams:
    """What the estimator knows of the probe (design values of the default rig: 0.42 mm flux sensor,
    15 × 15 mm, 2.0 W/(m·K), 5 Hz filter; the same constants as telethermo.control.core's R_sensor and
    contact's c_top).

    Attributes:
        R_half_K_per_W: thermal resistance from the thermocouple (mid-plane) to the contact face, K/W.
        area_m2: contact area, m².
        cutoff_Hz: the rig's 2nd-order Butterworth low-pass, Hz (0 = unfiltered signals).
        window_s: fit window after the touch, s (≤ 0.3 s).
        skip_s: samples this long after the touch are left out of the residuals, s (the sensor's own
            transient, ≈ 4 × its half's diffusion time; they still enter the integrals).
        pre_s: pre-contact averaging window, s.
        floor_ln: model floor added (in quadrature) to the standard error of ln b when classifying.
        c_store_J_per_K: heat capacity of the sensor's upper half, J/K (0.42 mm, 15 × 15 mm, ρc = 2 MJ/(m³·K):
            half of 0.19 J/K).
        top_store_J_per_K: the upper half's mean flux is the measured mean less this times dT_sensor/dt,
            J/K: C_half/2 = 0.0475 for a linear profile; 0.055 puts the clean semi-infinite touches of oak,
            glass, ceramic and copper (8 N, 20 mm, 20 °C) within 2.1 % of their effusivity (the graded
            profile of the sensor's fast transient).
        prior_T_object_C: prior mean of the object's initial temperature, °C (objects near ambient).
        prior_weight: weight of the prior row: a residual b·(prior − T_o0) counts like prior_weight × that
            many J of heat residual (1e-5: about a 5 °C prior σ against the fit's typical residual).
        prior_weight_C: the same prior in the flux form, a residual (prior − T_o0) counted × this, °C/°C.
        slope_half_width: time derivatives by central differences over ± this many samples.
        T_sigma_C, Q_sigma_W: the rig's measurement noise before its filter (1 σ; sim.measurement's
            defaults), for the noise part of the confidence.
        noise_draws: noise realisations drawn for it (0: residuals only); noise_seed: their seed.
    """

    R_half_K_per_W: float = 0.5 * 0.42e-3 / (2.0 * 0.015 * 0.015)
    area_m2: float = 0.015 * 0.015
    cutoff_Hz: float = 5.0
    window_s: float = 0.3
    skip_s: float = 0.2
    pre_s: float = 0.05
    floor_ln: float = 0.1
    c_store_J_per_K: float = 0.095
    prior_T_object_C: float = 25.0
    prior_weight: float = 1e-5
    prior_weight_C: float = 0.002
    slope_half_width: int = 1
    T_sigma_C: float = 0.02
    Q_sigma_W: float = 0.002
    noise_draws: int = 8
    noise_seed: int = 15
    top_store_J_per_K: float = 0.055


@dataclass(frozen=True, slots=True)
class EffusivityEstimate:
    """Result of one fit.

    Attributes:
        b: effusivity of the object, W·s^½/(m²·K).
        se_ln_b: standard error of ln b (dimensionless; ≈ relative error of b).
        T_object0_C: fitted initial temperature of the object, °C.
        R_contact_K_per_W: fitted contact resistance, K/W.
        residual_C: RMS residual of the fit, °C.
        n: samples used.
    """

    b: float
    se_ln_b: float
    T_object0_C: float
    R_contact_K_per_W: float
    residual_C: float
    n: int

    def interval(self, z: float = 1.96) -> tuple[float, float]:
        """Confidence interval of b, W·s^½/(m²·K) (``z`` standard errors of ln b each side)."""
        return self.b * math.exp(-z * self.se_ln_b), self.b * math.exp(z * self.se_ln_b)


@dataclass(frozen=True, slots=True)
class Classification:
    """Nearest table material.

    Attributes:
        index: 1-based position of the material in the table given (file order).
        name: its name.
        posterior: its posterior probability (equal priors).
        margin_sigma: (distance to the 2nd nearest − distance to the nearest) in ln b / σ.
    """

    index: int
    name: str
    posterior: float
    margin_sigma: float


def butter2_lowpass(cutoff_Hz: float, fs_Hz: float) -> tuple[tuple[float, float, float], tuple[float, float]]:
    """Coefficients (b0, b1, b2), (a1, a2) of the rig's 2nd-order Butterworth (bilinear, pre-warped, capped at
    0.4·Nyquist): the measurement chain the rigs document (sim/measurement.py; hardware: the node's
    filter)."""
    fc = min(cutoff_Hz, 0.4 * fs_Hz / 2.0)
    k = math.tan(math.pi * fc / fs_Hz)
    q = 1.0 / math.sqrt(2.0)
    norm = 1.0 / (1.0 + k / q + k * k)
    b0 = k * k * norm
    return (b0, 2.0 * b0, b0), (2.0 * (k * k - 1.0) * norm, (1.0 - k / q + k * k) * norm)


@functools.lru_cache(maxsize=16)
def filter_release(n: int, cutoff_Hz: float, dt_s: float) -> np.ndarray:
    """The filter's output for an input that is 1 before sample 0 (at rest) and 0 from sample 0 on
    (cached: read-only)."""
    if cutoff_Hz <= 0:
        return np.zeros(n)
    (b0, b1, b2), (a1, a2) = butter2_lowpass(cutoff_Hz, 1.0 / dt_s)
    z1, z2 = 1.0 - b0, b2 - a2  # at rest on 1 (sim.measurement.Biquad.reset)
    out = np.empty(n)
    for i in range(n):
        y = z1  # input 0
        z1, z2 = -a1 * y + z2, -a2 * y
        out[i] = y
    out.flags.writeable = False
    return out


@functools.lru_cache(maxsize=16)
def half_integral_matrix(n: int, dt_s: float, onset_s: float) -> np.ndarray:
    """Lower-triangular M with (M·f)[k] = I½[f](t_k) = 1/√π ∫ f(σ)/√(t_k − σ) dσ, s^½, sample j's value
    held over its cell [t_j − dt/2, t_j + dt/2], the first cell starting at the touch, ``onset_s`` before
    sample 0 (the rig flags the touch at the first sample after it). Cached: read-only."""
    t = np.arange(n) * dt_s
    a = t - 0.5 * dt_s
    a[0] = -onset_s
    b = t + 0.5 * dt_s
    tk, aj, bj = t[:, None], a[None, :], np.minimum(b[None, :], t[:, None])
    M = np.tril(
        2.0 * (np.sqrt(np.maximum(tk - aj, 0.0)) - np.sqrt(np.maximum(tk - bj, 0.0))) / math.sqrt(math.pi)
    )
    M.flags.writeable = False  # cached: shared by every fit with these settings
    return cast(np.ndarray, M)


def pre_samples(probe: ProbeParams, dt_s: float) -> int:
    """The samples kept before a touch (``probe.pre_s`` at period ``dt_s``, s; at least one)."""
    return max(1, int(round(probe.pre_s / dt_s)))


#: a fit window's signals (:func:`_window`): E (J), T_top·H (°C), q (W), the filter's release s
Window = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def _window(T: np.ndarray, Q: np.ndarray, i0: int, dt_s: float, probe: ProbeParams) -> Window | None:
    """(E, T_top, q, s) of the fit window, or None. All are the filtered signals of the touch alone (the
    pre-contact state removed with the filter's release ``s``): E the heat into the object since the touch,
    J (∫Q dt minus the heat stored in the sensor's upper half), T_top the contact face, °C, q the flux, W."""
    n_pre = pre_samples(probe, dt_s)
    n_win = int(round(probe.window_s / dt_s))
    if i0 < n_pre or T.shape != Q.shape or T.ndim != 1 or T.size < i0 + n_win or n_win < 6:
        return None
    Tw, Qw = T[i0 - n_pre : i0 + n_win], Q[i0 - n_pre : i0 + n_win]
    if not (np.isfinite(Tw).all() and np.isfinite(Qw).all()):
        return None
    Rh = probe.R_half_K_per_W
    T_pre, Q_pre = float(Tw[:n_pre].sum()) / n_pre, float(Qw[:n_pre].sum()) / n_pre  # np.mean's arithmetic
    Ta, Qa = Tw[n_pre:], Qw[n_pre:]
    s = filter_release(n_win, probe.cutoff_Hz, dt_s)
    q = Qa - Q_pre * s  # F[Q·H]
    # the contact face: below the thermocouple by R_half times the mean flux of the upper half, which is
    # the measured (thickness-mean) flux less half the heat the upper half stores
    dT_dt = _slope(Tw, dt_s, probe.slope_half_width)[n_pre:]
    top = Ta - Rh * (Qa - probe.top_store_J_per_K * dT_dt)  # F[T_top]
    top_H = top - (T_pre - Rh * Q_pre) * s  # F[T_top·H]
    stored = probe.c_store_J_per_K * 0.5 * ((Ta - T_pre) + (top - (T_pre - Rh * Q_pre)))
    E = dt_s * (np.cumsum(q) - 0.5 * q) - stored
    return E, top_H, q, s


@dataclass(frozen=True, eq=False)
class FitInput:
    """The samples of one touch's fit: ``T``, ``Q`` the window with ``n_pre`` samples before the touch,
    ``dt_s`` their period, s; ``w`` the window's signals (:func:`_window`)."""

    T: np.ndarray
    Q: np.ndarray
    n_pre: int
    dt_s: float
    w: Window


#: the two model forms, in the order they are fitted (one unit of work each, see :func:`fit_form`)
FORMS = ("energy", "flux")


def fit_input(
    T_sensor_C: ArrayLike, Q_W: ArrayLike, i_contact: int, dt_s: float, probe: ProbeParams = ProbeParams()
) -> FitInput | None:
    """The touch's window (``probe.pre_s`` before the first contact sample ``i_contact``, ``probe.window_s``
    after), or None when the samples are too few or not finite."""
    T, Q = np.asarray(T_sensor_C, float), np.asarray(Q_W, float)
    n_pre = pre_samples(probe, dt_s)
    i0 = int(i_contact)
    if T.ndim != 1 or T.shape != Q.shape or i0 < n_pre:
        return None
    i1 = i0 + int(round(probe.window_s / dt_s))
    T, Q = T[i0 - n_pre : i1], Q[i0 - n_pre : i1]
    w = _window(T, Q, n_pre, dt_s, probe)
    return FitInput(T, Q, n_pre, dt_s, w) if w is not None else None


def fit_form(inp: FitInput, form: str, probe: ProbeParams = ProbeParams()) -> EffusivityEstimate | None:
    """One model form (``"energy"`` or ``"flux"``) fitted to the window; se_ln_b from the residuals only."""
    f = _energy_form if form == "energy" else _flux_form
    return f(*inp.w, inp.dt_s, 0.5 * inp.dt_s, probe)


def noise_deviation(
    inp: FitInput, form: str, ln_b: float, k: int, probe: ProbeParams = ProbeParams()
) -> float:
    """Change of ln b when the ``k``-th realisation of the rig's documented noise (seeded by
    ``(probe.noise_seed, k)``, filtered like the signals) is added to the window and ``form`` refitted (1.0
    when the refit fails): the noise enters every later sample through the integrals, which the residuals do
    not show."""
    n, dt = inp.T.size, inp.dt_s
    nT, nQ = noise_realisation(probe.noise_seed, k, n, probe.T_sigma_C, probe.Q_sigma_W, probe.cutoff_Hz, dt)
    w = _window(inp.T + nT, inp.Q + nQ, inp.n_pre, dt, probe)
    e = fit_form(FitInput(inp.T, inp.Q, inp.n_pre, dt, w), form, probe) if w is not None else None
    return math.log(e.b) - ln_b if e is not None else 1.0


@functools.lru_cache(maxsize=64)
def noise_realisation(
    seed: int, k: int, n: int, T_sigma_C: float, Q_sigma_W: float, cutoff_Hz: float, dt_s: float
) -> tuple[np.ndarray, np.ndarray]:
    """The ``k``-th realisation of the rig's documented noise over ``n`` samples, filtered like the signals
    (°C, W; the filter run in over 50 samples first). Seeded by ``(seed, k)``, so the same for every touch:
    cached (read-only), a noise unit of the fit does not redraw and refilter it inside a control cycle."""
    rng = np.random.default_rng((seed, k))
    nT = lowpass(T_sigma_C * rng.standard_normal(n + 50), cutoff_Hz, dt_s)[50:]
    nQ = lowpass(Q_sigma_W * rng.standard_normal(n + 50), cutoff_Hz, dt_s)[50:]
    nT.flags.writeable = False
    nQ.flags.writeable = False
    return nT, nQ


def best_form(fits: list[tuple[str, EffusivityEstimate | None]]) -> tuple[str, EffusivityEstimate] | None:
    """The form with the smaller standard error of ln b (the energy form wins on insulators, the flux form
    on metals behind a contact resistance), or None when neither fitted."""
    ok = [(f, e) for f, e in fits if e is not None]
    return min(ok, key=lambda fe: fe[1].se_ln_b) if ok else None


def with_noise_spread(est: EffusivityEstimate, deviations: list[float]) -> EffusivityEstimate:
    """The estimate with the RMS of the noise deviations combined (in quadrature) into its se_ln_b."""
    spread = math.sqrt(float(np.mean(np.square(deviations)))) if deviations else 0.0
    return replace(est, se_ln_b=math.hypot(est.se_ln_b, spread))


def noise_draws(probe: ProbeParams) -> int:
    """How many noise realisations the confidence draws (0 when the probe documents no noise)."""
    return probe.noise_draws if probe.T_sigma_C > 0 or probe.Q_sigma_W > 0 else 0


def estimate_effusivity(
    T_sensor_C: ArrayLike, Q_W: ArrayLike, i_contact: int, dt_s: float, probe: ProbeParams = ProbeParams()
) -> EffusivityEstimate | None:
    """Fit the object's effusivity from the samples around a touch (pure; all stages at once: the slave's
    core spreads the same stages over several cycles, telethermo.control.material_stream).

    ``T_sensor_C``, ``Q_W``: the rig's samples, period ``dt_s`` s; ``i_contact``: index of the first sample
    with the contact flag. Uses ``probe.pre_s`` before and ``probe.window_s`` after. Energy form of the
    module docstring's relation (smooth where the flux is singular): the heat into a semi-infinite object
    is E = b·A·I½[T_os − T_o0], I½ the half-integral, T_os = T_top − R_c·q, so

        E = b·A·I½[T_top·H] − (b·T_o0)·A·I½[H] − (b·R_c)·A·I½[q·H],

    linear in (b, b·T_o0, b·R_c); and its flux form. Returns None when the samples are too few, not finite,
    or carry no information.
    """
    inp = fit_input(T_sensor_C, Q_W, i_contact, dt_s, probe)
    if inp is None:
        return None
    best = best_form([(f, fit_form(inp, f, probe)) for f in FORMS])
    if best is None:
        return None
    form, est = best
    ln_b = math.log(est.b)
    return with_noise_spread(
        est, [noise_deviation(inp, form, ln_b, k, probe) for k in range(noise_draws(probe))]
    )


def lowpass(x: np.ndarray, cutoff_Hz: float, dt_s: float) -> np.ndarray:
    """The rig's filter (:func:`butter2_lowpass`) applied to x from rest."""
    if cutoff_Hz <= 0:
        return x
    (b0, b1, b2), (a1, a2) = butter2_lowpass(cutoff_Hz, 1.0 / dt_s)
    y = np.empty_like(x)
    z1 = z2 = 0.0
    for i, v in enumerate(x.tolist()):
        out = b0 * v + z1
        z1, z2 = b1 * v - a1 * out + z2, b2 * v - a2 * out
        y[i] = out
    return y


def _energy_form(
    E: np.ndarray,
    top_H: np.ndarray,
    q: np.ndarray,
    s: np.ndarray,
    dt_s: float,
    onset_s: float,
    probe: ProbeParams,
) -> EffusivityEstimate | None:
    """E = b·A·I½[T_top·H] − (b·T_o0)·A·I½[H] − (b·R_c)·A·I½[q·H]: θ = (b, b·T_o0, b·R_c)."""
    a = probe.area_m2  # A·I½ of the three signals in one product (the cached matrix is never rescaled)
    X = (half_integral_matrix(E.size, dt_s, onset_s) @ np.column_stack([top_H, 1.0 - s, q])) * (a, -a, -a)
    k0 = int(round(probe.skip_s / dt_s))
    wp = probe.prior_weight
    fit = _fit(X[k0:], E[k0:], wp * np.array([probe.prior_T_object_C, -1.0, 0.0]), 0.0, 0)
    if fit is None:
        return None
    theta, se_b, resid = fit
    b = float(theta[0])
    return EffusivityEstimate(
        b=b,
        se_ln_b=se_b / b,
        T_object0_C=float(theta[1] / b),
        R_contact_K_per_W=float(theta[2] / b),
        residual_C=math.sqrt(float(resid @ resid) / resid.size) / (b * probe.area_m2 * 0.5),
        n=int(resid.size),
    )


def _flux_form(
    E: np.ndarray,
    top_H: np.ndarray,
    q: np.ndarray,
    s: np.ndarray,
    dt_s: float,
    onset_s: float,
    probe: ProbeParams,
) -> EffusivityEstimate | None:
    """T_top·H = T_o0·H + (1/b)·I½[q_top]/A + R_c·q_top, q_top = dE/dt: θ = (T_o0, 1/b, R_c)."""
    q_top = _slope(E, dt_s, probe.slope_half_width)
    X = np.column_stack(
        [1.0 - s, (half_integral_matrix(E.size, dt_s, onset_s) @ q_top) / probe.area_m2, q_top]
    )
    k0 = int(round(probe.skip_s / dt_s))
    wt = probe.prior_weight_C
    fit = _fit(X[k0:], top_H[k0:], wt * np.array([1.0, 0.0, 0.0]), wt * probe.prior_T_object_C, 1)
    if fit is None:
        return None
    theta, se_inv_b, resid = fit
    inv_b = float(theta[1])
    return EffusivityEstimate(
        b=1.0 / inv_b,
        se_ln_b=se_inv_b / inv_b,
        T_object0_C=float(theta[0]),
        R_contact_K_per_W=float(theta[2]),
        residual_C=math.sqrt(float(resid @ resid) / resid.size),
        n=int(resid.size),
    )


def _fit(
    X: np.ndarray, y: np.ndarray, prior_row: np.ndarray, prior_y: float, i_pos: int
) -> tuple[np.ndarray, float, np.ndarray] | None:
    """Least squares of y on X's three columns plus one prior row (all zero: none); the last parameter (the
    contact resistance's) is kept >= 0 (refit without it), parameter ``i_pos`` must come out > 0.
    Returns (θ, standard error of θ[i_pos], residuals) or None."""
    use_prior = bool(np.any(prior_row))
    Xc = np.vstack([X, prior_row]) if use_prior else X
    yc = np.append(y, prior_y) if use_prior else y
    normal = NormalEquations(Xc, yc)
    for cols in (3, 2):
        solved = normal.solve(cols)
        if solved is None:
            return None
        theta_l, cov_l = solved
        theta = np.array(theta_l)
        if cols == 3 and theta[2] < 0:
            continue
        if not theta[i_pos] > 0:
            return None
        resid = y - X[:, :cols] @ theta
        n = resid.size
        rho = _lag1(resid)
        sigma2 = float(resid @ resid) / max(n - cols, 1) * (1.0 + rho) / (1.0 - rho)
        theta = np.append(theta, 0.0) if cols == 2 else theta
        return theta, math.sqrt(max(sigma2 * cov_l[i_pos][i_pos], 0.0)), resid
    return None


def _slope(x: np.ndarray, dt_s: float, h: int) -> np.ndarray:
    """d/dt by central differences over ±h samples (one-sided, narrower, at the ends): the filtered
    signals carry nothing above a few Hz, and a wider difference keeps the noise out of the slope."""
    n = x.size
    i = np.arange(n)
    lo, hi = np.maximum(i - h, 0), np.minimum(i + h, n - 1)
    return cast(np.ndarray, (x[hi] - x[lo]) / ((hi - lo) * dt_s))


def _lag1(r: np.ndarray) -> float:
    """Lag-1 autocorrelation of the residuals, clipped to [0, 0.95]."""
    d = float(r @ r)
    if d <= 0 or r.size < 3:
        return 0.0
    return min(max(float(r[1:] @ r[:-1]) / d, 0.0), 0.95)


def classify(est: EffusivityEstimate, table: dict[str, float], floor_ln: float = 0.1) -> Classification:
    """Nearest material of ``table`` (name -> effusivity, W·s^½/(m²·K), in file order) in ln b."""
    names = list(table)
    lb = np.log(np.array([table[k] for k in names], float))
    sig = math.hypot(est.se_ln_b, floor_ln)
    d = np.abs(lb - math.log(est.b))
    order = np.argsort(d)
    ll = -0.5 * ((lb - math.log(est.b)) / sig) ** 2
    post = np.exp(ll - ll.max())
    post /= post.sum()
    i = int(order[0])
    margin = float((d[order[1]] - d[i]) / sig) if len(names) > 1 else math.inf
    return Classification(index=i + 1, name=names[i], posterior=float(post[i]), margin_sigma=margin)


def load_effusivity_table(path: str | Path | None = None) -> dict[str, float]:
    """Material -> effusivity (W·s^½/(m²·K)) of the rendering-table entries that give ``effusivity``, in file
    order; errors name the file and the field."""
    path = Path(path) if path is not None else DEFAULT_RENDER_TABLE
    top = Section(path, "", load_toml(path, what="a rendering table (TOML)"))
    return {
        name: top.table(name).float("effusivity", positive=True)
        for name, entry in top.raw.items()
        if isinstance(entry, dict) and "effusivity" in entry
    }
