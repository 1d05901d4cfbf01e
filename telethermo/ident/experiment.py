"""The identification experiment on a rig: PRBS excitation, recording, fit, held-out validation.

Protocol of :func:`identify_rig` (guiatni §3.3, on a pad that touches nothing, so that the sensor
temperature is the pad temperature up to the tiny air flux):

1. ``rest_samples`` at zero current: the reference (ambient) temperature T_ref_C of the model. The rig
   must start at rest (pad at ambient); the report's ``rest_drift_C`` (last minus first quarter of
   the rest samples) shows whether it did.
2. ``n_samples`` of training PRBS (variable amplitude, seed ``seed``).
3. ``n_validation`` of held-out PRBS (seed ``seed + 1``: a different sequence, never used to fit).

The temperature model (eq. 10) and the heat-flux model (eq. 12) are fitted on 1+2. The held-out error
is that of the model **free-running from the start of the experiment** (at rest) through training into
validation, taken on the validation samples only: the way a node runs the predictor, with its errors
accumulated over the whole record, not re-initialised from measurements.

Safety: the commanded current is limited to ``current_limit_fraction`` x the rig's I_max_A, and a guard
flips its sign whenever the sensor temperature comes within ``margin_C`` of the safety envelope
[T_min_C, T_max_C] (DESIGN.md §6) and the current would push it further; every intervention is
counted in the report. The data stay valid for identification: the model is fitted on the currents
actually commanded.
"""
from __future__ import annotations

import math
import os
import time
from pathlib import Path
from dataclasses import asdict, dataclass, field, replace
from typing import Any, Callable

import numpy as np

from telethermo.ident.capacity import CapacityModel, fit_capacity
from telethermo.ident.flux import fit_flux_arma
from telethermo.ident.modelfile import TemModel
from telethermo.ident.narma import NarmaModel, NarmaOrders
from telethermo.ident.narma_fit import fit_narma
from telethermo.ident.plan import IdentifyPlan, guarded_current
from telethermo.ident.stability import check_stability
from telethermo.rig import Rig
from telethermo.atomic import write_text_atomic

Progress = Callable[[int, int], None]


@dataclass(frozen=True)
class ExperimentSettings:
    """Settings of the identification experiment (defaults: guiatni §3.3 at 10 ms, on our default rig).

    Attributes:
        rest_samples: samples at zero current before the PRBS (reference temperature).
        amplitude_A: range of the PRBS bit amplitudes, A.
        hold_samples: PRBS clock divider, samples per bit.
        current_limit_fraction: |I| <= this x rig.I_max_A (safety envelope: 0.8).
        T_min_C, T_max_C: safety envelope of the pad, °C; margin_C: guard distance to it, °C.
        flux_orders: (n, m) of the heat-flux ARMA model (eq. 12).
        flux_with_current: give the flux model the current terms (see telethermo.ident.flux).
        capacity_points: N steady states for the capacity model (guiatni: 14).
        capacity_current_span_A: the currents are spread over this span (guiatni: ±1.5 A) **clipped to
            the currents whose steady state stays inside the safety envelope** (see
            :func:`capacity_currents`), A.
        settle_s, settle_step_s: settling time per steady state and the step it is advanced by, s
            (a simulated rig may take long steps: its integrator is exact for a held current).
        average_samples: samples averaged (at the rig's period) per steady state.
    """

    rest_samples: int = 200
    amplitude_A: tuple[float, float] = (0.1, 1.0)
    hold_samples: int = 25
    current_limit_fraction: float = 0.8
    T_min_C: float = 15.0
    T_max_C: float = 43.0
    margin_C: float = 1.0
    flux_orders: tuple[int, int] = (3, 3)
    flux_with_current: bool = True
    capacity_points: int = 14
    capacity_current_span_A: tuple[float, float] = (-1.5, 1.5)
    settle_s: float = 2000.0
    settle_step_s: float = 50.0
    average_samples: int = 300

    def plan(self, *, seed: int, train_samples: int, validation_samples: int) -> IdentifyPlan:
        """The experiment of these settings as an :class:`~telethermo.ident.plan.IdentifyPlan`."""
        return IdentifyPlan(seed=seed, rest_samples=self.rest_samples, train_samples=train_samples,
                            validation_samples=validation_samples, amplitude_A=self.amplitude_A,
                            hold_samples=self.hold_samples, margin_C=self.margin_C)

    def __post_init__(self) -> None:
        def bad(name: str, expected: str) -> ValueError:
            return ValueError(f"ExperimentSettings.{name}: expected {expected}, got {getattr(self, name)!r}")

        for name, lo in (("rest_samples", 0), ("hold_samples", 1), ("capacity_points", 5), ("average_samples", 1)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < lo:
                raise bad(name, f"an integer >= {lo}")
        a_lo, a_hi = self.amplitude_A
        if not (0.0 <= a_lo <= a_hi and math.isfinite(a_hi)):
            raise bad("amplitude_A", "(a_min, a_max) with 0 <= a_min <= a_max, A")
        if not 0.0 < self.current_limit_fraction <= 1.0:
            raise bad("current_limit_fraction", "a fraction in (0, 1]")
        if not (self.T_min_C + 2 * self.margin_C < self.T_max_C and self.margin_C >= 0.0):
            raise bad("T_max_C", "T_min_C + 2·margin_C < T_max_C with margin_C >= 0, °C")
        if not (self.settle_s > 0.0 and self.settle_step_s > 0.0):
            raise bad("settle_s", "positive settle_s and settle_step_s, s")
        c_lo, c_hi = self.capacity_current_span_A
        if not c_lo <= 0.0 <= c_hi:
            raise bad("capacity_current_span_A", "(lo, hi) with lo <= 0 <= hi, A")


@dataclass
class Record:
    """What an experiment recorded, one row per sample (arrays of equal length).

    ``current_A[k]`` is the current commanded right after sample k (held until sample k+1);
    ``T_C``, ``Q_W``, ``T_sink_C`` are the rig's sample k; ``Q_true_W`` the simulator's true flux (NaN on
    hardware).
    """

    t_s: np.ndarray
    current_A: np.ndarray
    T_C: np.ndarray
    Q_W: np.ndarray
    T_sink_C: np.ndarray
    Q_true_W: np.ndarray
    guard_interventions: int = 0


def run_excitation(rig: Rig, current_A: np.ndarray, *, settings: ExperimentSettings = ExperimentSettings(),
                   progress: Progress | None = None, progress_offset: int = 0, progress_total: int | None = None
                   ) -> Record:
    """Apply ``current_A`` to ``rig`` sample by sample (through the safety guard) and record.

    A simulated rig (one with ``advance``) is advanced by one period per sample; a hardware rig is
    expected to advance by itself (not supported here yet: this needs a node's SYNC clock).
    """
    if not hasattr(rig, "advance"):
        raise TypeError("run_excitation drives simulated rigs (rig.advance); live nodes are not supported yet")
    u = np.asarray(current_A, dtype=float)
    N = len(u)
    dt = float(rig.period_s)
    I_lim = settings.current_limit_fraction * float(rig.I_max_A)
    truth = getattr(rig, "truth", None)
    t_s, I_out, T, Q, Ts, Qt = (np.empty(N) for _ in range(6))
    guard = 0
    total = progress_total if progress_total is not None else N
    step = max(1, total // 200)
    for k in range(N):
        s = rig.read()
        i, guarded = guarded_current(u[k], s.T_sensor_C, I_limit_A=I_lim, T_min_C=settings.T_min_C,
                                     T_max_C=settings.T_max_C, margin_C=settings.margin_C)
        guard += guarded
        rig.apply_current(i)
        t_s[k], I_out[k], T[k], Q[k], Ts[k] = s.t_s, i, s.T_sensor_C, s.Q_W, s.T_sink_C
        Qt[k] = truth().Q_true_W if truth is not None else math.nan
        rig.advance(dt)
        if progress is not None and (k % step == 0 or k == N - 1):
            progress(progress_offset + k + 1, total)
    return Record(t_s, I_out, T, Q, Ts, Qt, guard)


def _concat(records: list[Record]) -> Record:
    def cat(f: str) -> np.ndarray:
        return np.concatenate([getattr(r, f) for r in records])

    return Record(cat("t_s"), cat("current_A"), cat("T_C"), cat("Q_W"), cat("T_sink_C"), cat("Q_true_W"),
                  guard_interventions=sum(r.guard_interventions for r in records))


def _rest_drift(T: np.ndarray) -> float:
    """Mean of the last quarter minus mean of the first quarter of the rest samples, °C (0 if too few)."""
    q = len(T) // 4
    return float(np.mean(T[-q:]) - np.mean(T[:q])) if q else 0.0


def identify_rig(rig: Rig, *, n_samples: int = 10_000, orders: NarmaOrders = NarmaOrders(), seed: int = 0,
                 progress: Progress | None = None, n_validation: int | None = None,
                 settings: ExperimentSettings = ExperimentSettings(), meta: dict[str, Any] | None = None,
                 method: str = "oe", capacity: bool = False, keep_record: bool = False
                 ) -> tuple[TemModel, dict[str, Any]]:
    """Run the identification experiment on ``rig`` (see the module docstring) and fit the models.

    Args:
        rig: a simulated rig (``sim.free_pad_rig()``) whose pad touches nothing.
        n_samples: training PRBS length, samples (guiatni: M = 10,000 at 10 ms).
        orders: NARMA orders.
        seed: PRBS seed (training ``seed``, validation ``seed + 1``).
        progress: called as ``progress(done, total)`` while the experiment runs.
        n_validation: held-out PRBS length, samples (default n_samples // 2).
        settings: experiment settings.
        meta: extra provenance for the model file.
        method: NARMA fit: ``"oe"`` (least squares, then output-error refinement; default) or ``"ls"``.
        capacity: also run the capacity experiment (:func:`identify_capacity`) after the dynamic one.
        keep_record: put the recorded data and predictions in ``report["record"]`` (for plots).

    Returns:
        ``(TemModel, report)``; ``report`` holds the held-out free-run errors (°C), flux errors (W), the
        stability verdict, guard interventions and timings.

    Raises:
        telethermo.ident.narma.UnstableModelError: the fitted model is unstable (refused).
    """
    if n_validation is None:
        n_validation = max(n_samples // 2, 1)
    if n_samples < 1 or n_validation < 1:
        raise ValueError(f"n_samples and n_validation must be >= 1, got {n_samples}, {n_validation}")
    plan = settings.plan(seed=seed, train_samples=n_samples, validation_samples=n_validation)
    t0 = time.perf_counter()
    rec = run_excitation(rig, plan.currents(), settings=settings, progress=progress)
    t_experiment = time.perf_counter() - t0
    tem, report = fit_experiment(rec, plan=plan, orders=orders, period_s=float(rig.period_s), settings=settings,
                                 method=method, meta=meta, keep_record=keep_record)
    report["experiment_wall_s"] = t_experiment
    if capacity:
        cap, ss = identify_capacity(rig, tem.temperature, settings=settings)
        if keep_record:
            report["steady_states"] = ss
        report.update({"capacity_points": len(ss.current_A), "capacity_current_range_A": [float(ss.current_A.min()),
                       float(ss.current_A.max())], "capacity_rms_W": cap.metrics["rms_W"],
                       "capacity_max_abs_W": cap.metrics["max_abs_W"], "capacity_skipped_A": ss.skipped})
        tem = replace(tem, capacity=cap)
    return tem, report


def save_record_csv(path: str | os.PathLike[str], rec: Record, plan: IdentifyPlan, *,
                    comments: dict[str, Any] | None = None) -> Path:
    """Write the experiment's samples as CSV, atomically: ``j, phase, t_s, current_A, T_sensor_C, Q_W`` (one row
    per sample of ``plan``; ``current_A`` is the current commanded after sample j). ``comments`` become
    ``# key: value`` lines first. Returns the path."""
    lines = [f"# {k}: {v}" for k, v in (comments or {}).items()]
    lines.append("j,phase,t_s,current_A,T_sensor_C,Q_W")
    lines += [f"{j},{plan.phase(j)},{t!r},{i!r},{T!r},{q!r}" for j, (t, i, T, q) in
              enumerate(zip(rec.t_s.tolist(), rec.current_A.tolist(), rec.T_C.tolist(), rec.Q_W.tolist()))]
    return write_text_atomic(path, "\n".join(lines) + "\n")


def record_slice(rec: Record, start: int, stop: int) -> Record:
    """Rows ``start:stop`` of a record (guard interventions are those of the whole record)."""
    rows = slice(start, stop)
    return Record(rec.t_s[rows], rec.current_A[rows], rec.T_C[rows], rec.Q_W[rows], rec.T_sink_C[rows],
                  rec.Q_true_W[rows], guard_interventions=rec.guard_interventions)


def fit_experiment(rec: Record, *, plan: IdentifyPlan, orders: NarmaOrders = NarmaOrders(), period_s: float,
                   settings: ExperimentSettings = ExperimentSettings(), method: str = "oe",
                   meta: dict[str, Any] | None = None, keep_record: bool = False,
                   source: str = "telethermo.ident.experiment.identify_rig") -> tuple[TemModel, dict[str, Any]]:
    """Fit the temperature (eq. 10) and heat-flux (eq. 12) models on the record of ``plan`` and validate them
    on its held-out part: the fitting half of :func:`identify_rig`, for a record made anywhere (a simulated
    rig here, a live node's samples streamed over the bus by ``telethermo identify <node>``).

    ``rec`` holds ``plan.total`` rows in the order of the plan (rest, training, held-out). The report has
    the same keys as :func:`identify_rig`'s (``experiment_wall_s`` is left to the caller).
    """
    if len(rec.T_C) != plan.total:
        raise ValueError(f"fit_experiment: the record has {len(rec.T_C)} samples; the plan has {plan.total}")
    n_rest, n_fit = plan.rest_samples, plan.fit_samples
    fit_rec = record_slice(rec, 0, n_fit)
    allrec = rec
    rest_T = rec.T_C[:n_rest]
    T_ref = float(np.mean(rest_T)) if n_rest else float(rec.T_C[0])

    t1 = time.perf_counter()
    model = fit_narma(current_A=fit_rec.current_A, T_C=fit_rec.T_C, orders=orders, period_s=float(period_s),
                      T_ref_C=T_ref, method=method)
    t_fit = time.perf_counter() - t1
    fr = model.free_run(current_A=allrec.current_A, T0_C=T_ref)
    e_val = (fr - allrec.T_C)[n_fit:]
    os_ = model.predict_one_step(current_A=allrec.current_A, T_C=allrec.T_C)
    e_os = (os_ - allrec.T_C)[n_fit:]
    stab = check_stability(model)
    metrics = dict(model.metrics)
    metrics.update({
        "heldout_free_run_max_C": float(np.max(np.abs(e_val))),
        "heldout_free_run_rms_C": float(np.sqrt(np.mean(e_val ** 2))),
        "heldout_one_step_max_C": float(np.max(np.abs(e_os))),
        "heldout_one_step_rms_C": float(np.sqrt(np.mean(e_os ** 2))),
        "heldout_samples": int(plan.validation_samples),
    })
    object.__setattr__(model, "metrics", metrics)

    fn, fm = settings.flux_orders
    t2 = time.perf_counter()
    flux = fit_flux_arma(T_C=fit_rec.T_C, Q_W=fit_rec.Q_W, n=fn, m=fm, period_s=float(period_s), T_ref_C=T_ref,
                         current_A=fit_rec.current_A if settings.flux_with_current else None)
    t_flux = time.perf_counter() - t2
    fe = flux.errors(T_C=allrec.T_C, Q_W=allrec.Q_W, current_A=allrec.current_A, start=n_fit)
    fmetrics = dict(flux.metrics)
    fmetrics.update({"heldout_free_run_max_W": fe["free_run_max_W"], "heldout_free_run_rms_W": fe["free_run_rms_W"]})
    object.__setattr__(flux, "metrics", fmetrics)

    report: dict[str, Any] = {
        "orders": orders.as_dict(), "period_s": float(period_s), "seed": int(plan.seed),
        "n_train": int(plan.train_samples), "n_validation": int(plan.validation_samples), "rest_samples": n_rest,
        "T_ref_C": T_ref,
        "rest_drift_C": _rest_drift(rest_T),
        "heldout_free_run_max_C": metrics["heldout_free_run_max_C"],
        "heldout_free_run_rms_C": metrics["heldout_free_run_rms_C"],
        "heldout_one_step_max_C": metrics["heldout_one_step_max_C"],
        "train_one_step_rms_C": metrics["rms_one_step_C"],
        "flux_heldout_max_W": fmetrics["heldout_free_run_max_W"],
        "flux_heldout_rms_W": fmetrics["heldout_free_run_rms_W"],
        "flux_with_current": flux.with_current,
        "stable": stab.stable, "stability_reason": stab.reason, "max_pole_modulus": stab.max_pole_modulus,
        "stability_free_run_max_dev_C": stab.free_run_max_dev_C,
        "guard_interventions": allrec.guard_interventions,
        "current_range_A": list(model.current_range_A), "T_range_C": [float(allrec.T_C.min()), float(allrec.T_C.max())],
        "experiment_wall_s": math.nan, "fit_wall_s": t_fit, "flux_fit_wall_s": t_flux,
        "fit_method": method,
        "settings": asdict(settings),
        "plan": plan.as_dict(),
    }
    if keep_record:
        report["record"] = {"t_s": allrec.t_s, "current_A": allrec.current_A, "T_C": allrec.T_C, "Q_W": allrec.Q_W,
                            "T_pred_C": fr, "Q_pred_W": flux.free_run(T_C=allrec.T_C, current_A=allrec.current_A),
                            "n_fit": n_fit}
    tem_meta = {"source": source, "seed": int(plan.seed),
                "n_train": int(plan.train_samples), "n_validation": int(plan.validation_samples),
                "settings": asdict(settings)}
    tem_meta.update(meta or {})
    return TemModel(temperature=model, flux=flux, capacity=None, meta=tem_meta), report


def capacity_currents(model: NarmaModel, *, settings: ExperimentSettings = ExperimentSettings(),
                      I_max_A: float = math.inf) -> np.ndarray:
    """The N currents of the capacity experiment, A: evenly spread over the widest interval around 0 inside
    ``settings.capacity_current_span_A`` and ±current_limit_fraction·I_max_A whose steady state, as predicted
    by the identified temperature model, stays inside the safety envelope with its margin (then 10 %
    back from that edge).

    (On a pad in air ±1.5 A would settle far outside [15, 43] °C: 167 °C at +1.5 A on the default
    simulated rig.) Raises ValueError if no interval around 0 is safe.
    """
    lo_span, hi_span = settings.capacity_current_span_A
    lim = settings.current_limit_fraction * I_max_A
    lo_span, hi_span = max(lo_span, -lim), min(hi_span, lim)
    t_lo, t_hi = settings.T_min_C + settings.margin_C, settings.T_max_C - settings.margin_C
    grid_hi = np.linspace(0.0, hi_span, 301)
    grid_lo = np.linspace(0.0, lo_span, 301)

    def reach(grid: np.ndarray) -> float:
        Tss = model.steady_state_C(grid)
        ok = (Tss >= t_lo) & (Tss <= t_hi) & np.isfinite(Tss)
        if not ok[0]:
            raise ValueError(f"the rest temperature {float(Tss[0]):.2f} °C is outside the envelope [{t_lo}, {t_hi}] °C")
        bad = np.flatnonzero(~ok)
        return float(grid[bad[0] - 1]) if bad.size else float(grid[-1])

    # 10 % back from the predicted edge: the model's steady state is an extrapolation in T
    return np.linspace(0.9 * reach(grid_lo), 0.9 * reach(grid_hi), settings.capacity_points)


@dataclass
class SteadyStates:
    """Steady states of a rig: current (A), sensor temperature (°C), heat flux (W), sink temperature (°C) and,
    on a simulated rig, the true flux (W); ``skipped`` lists currents dropped by the safety guard."""

    current_A: np.ndarray
    T_C: np.ndarray
    Q_W: np.ndarray
    T_sink_C: np.ndarray
    Q_true_W: np.ndarray
    skipped: list[float] = field(default_factory=list)


def steady_state_points(rig: Rig, currents_A: np.ndarray, *, settings: ExperimentSettings = ExperimentSettings(),
                        progress: Progress | None = None) -> SteadyStates:
    """Hold each current until steady state (``settle_s``), then average ``average_samples`` samples.

    The safety guard checks the sensor temperature after every settling step; a current whose
    settling leaves the envelope (with margin) is cut to 0 and skipped (listed in ``skipped``).
    """
    if not hasattr(rig, "advance"):
        raise TypeError("steady_state_points drives simulated rigs (rig.advance)")
    lo, hi = settings.T_min_C + settings.margin_C, settings.T_max_C - settings.margin_C
    truth = getattr(rig, "truth", None)
    rows, skipped = [], []
    n_steps = max(1, int(math.ceil(settings.settle_s / settings.settle_step_s)))
    for idx, I in enumerate(np.asarray(currents_A, dtype=float)):
        rig.apply_current(float(I))
        safe = True
        for _ in range(n_steps):
            rig.advance(settings.settle_s / n_steps)
            T = rig.read().T_sensor_C
            if not (lo <= T <= hi):
                safe = False
                break
        if not safe:
            rig.apply_current(0.0)
            skipped.append(float(I))
            for _ in range(n_steps):
                rig.advance(settings.settle_s / n_steps)
            continue
        acc = np.zeros(4)
        for _ in range(settings.average_samples):
            rig.advance(float(rig.period_s))
            smp = rig.read()
            acc += (smp.T_sensor_C, smp.Q_W, smp.T_sink_C, truth().Q_true_W if truth is not None else math.nan)
        rows.append((float(I), *(acc / settings.average_samples)))
        if progress is not None:
            progress(idx + 1, len(currents_A))
    rig.apply_current(0.0)
    arr = np.array(rows, dtype=float).reshape(-1, 5)
    return SteadyStates(arr[:, 0], arr[:, 1], arr[:, 2], arr[:, 3], arr[:, 4], skipped)


def identify_capacity(rig: Rig, model: NarmaModel, *, settings: ExperimentSettings = ExperimentSettings(),
                      progress: Progress | None = None) -> tuple[CapacityModel, SteadyStates]:
    """The capacity experiment (guiatni §3.2): N steady states at currents from :func:`capacity_currents`,
    then eq. 13 fitted by least squares. P = the measured heat out of the pad (Q_W)."""
    currents = capacity_currents(model, settings=settings, I_max_A=float(rig.I_max_A))
    ss = steady_state_points(rig, currents, settings=settings, progress=progress)
    cap = fit_capacity(current_A=ss.current_A, T_C=ss.T_C, P_W=ss.Q_W)
    m = dict(cap.metrics)
    m.update({"skipped_currents_A": ss.skipped, "settle_s": settings.settle_s,
              "average_samples": settings.average_samples})
    object.__setattr__(cap, "metrics", m)
    return cap, ss
