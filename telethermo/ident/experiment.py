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
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np

# the capacity experiment and the settings live in their own modules; their names stay importable here
from telethermo.ident.capacity_experiment import SteadyStates as SteadyStates
from telethermo.ident.capacity_experiment import capacity_currents as capacity_currents
from telethermo.ident.capacity_experiment import identify_capacity as identify_capacity
from telethermo.ident.capacity_experiment import steady_state_points as steady_state_points
from telethermo.ident.experiment_settings import ExperimentSettings as ExperimentSettings
from telethermo.ident.experiment_settings import Progress as Progress
from telethermo.ident.flux import FluxArma, fit_flux_arma
from telethermo.ident.modelfile import TemModel
from telethermo.ident.narma import NarmaModel, NarmaOrders
from telethermo.ident.narma_fit import fit_narma
from telethermo.ident.plan import IdentifyPlan, guarded_current
from telethermo.ident.stability import check_stability
from telethermo.rig import Rig
from telethermo.atomic import write_text_atomic


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


def run_excitation(
    rig: Rig,
    current_A: np.ndarray,
    *,
    settings: ExperimentSettings = ExperimentSettings(),
    progress: Progress | None = None,
    progress_offset: int = 0,
    progress_total: int | None = None,
) -> Record:
    """Apply ``current_A`` to ``rig`` sample by sample (through the safety guard) and record.

    A simulated rig (one with ``advance``) is advanced by one period per sample; a hardware rig is
    expected to advance by itself (not supported here yet: this needs a node's SYNC clock).
    """
    if not hasattr(rig, "advance"):
        raise TypeError(
            "run_excitation drives simulated rigs (rig.advance); live nodes are not supported yet"
        )
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
        i, guarded = guarded_current(
            u[k],
            s.T_sensor_C,
            I_limit_A=I_lim,
            T_min_C=settings.T_min_C,
            T_max_C=settings.T_max_C,
            margin_C=settings.margin_C,
        )
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

    return Record(
        cat("t_s"),
        cat("current_A"),
        cat("T_C"),
        cat("Q_W"),
        cat("T_sink_C"),
        cat("Q_true_W"),
        guard_interventions=sum(r.guard_interventions for r in records),
    )


def _rest_drift(T: np.ndarray) -> float:
    """Mean of the last quarter minus mean of the first quarter of the rest samples, °C (0 if too few)."""
    q = len(T) // 4
    return float(np.mean(T[-q:]) - np.mean(T[:q])) if q else 0.0


def identify_rig(
    rig: Rig,
    *,
    n_samples: int = 10_000,
    orders: NarmaOrders = NarmaOrders(),
    seed: int = 0,
    progress: Progress | None = None,
    n_validation: int | None = None,
    settings: ExperimentSettings = ExperimentSettings(),
    meta: dict[str, Any] | None = None,
    method: str = "oe",
    capacity: bool = False,
    keep_record: bool = False,
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
    tem, report = fit_experiment(
        rec,
        plan=plan,
        orders=orders,
        period_s=float(rig.period_s),
        settings=settings,
        method=method,
        meta=meta,
        keep_record=keep_record,
    )
    report["experiment_wall_s"] = t_experiment
    if capacity:
        cap, ss = identify_capacity(rig, tem.temperature, settings=settings)
        if keep_record:
            report["steady_states"] = ss
        report.update(
            {
                "capacity_points": len(ss.current_A),
                "capacity_current_range_A": [float(ss.current_A.min()), float(ss.current_A.max())],
                "capacity_rms_W": cap.metrics["rms_W"],
                "capacity_max_abs_W": cap.metrics["max_abs_W"],
                "capacity_skipped_A": ss.skipped,
            }
        )
        tem = replace(tem, capacity=cap)
    return tem, report


def save_record_csv(
    path: str | os.PathLike[str], rec: Record, plan: IdentifyPlan, *, comments: dict[str, Any] | None = None
) -> Path:
    """Write the experiment's samples as CSV, atomically: ``j, phase, t_s, current_A, T_sensor_C, Q_W``
    (one row per sample of ``plan``; ``current_A`` is the current commanded after sample j). ``comments``
    become ``# key: value`` lines first. Returns the path."""
    lines = [f"# {k}: {v}" for k, v in (comments or {}).items()]
    lines.append("j,phase,t_s,current_A,T_sensor_C,Q_W")
    lines += [
        f"{j},{plan.phase(j)},{t!r},{i!r},{T!r},{q!r}"
        for j, (t, i, T, q) in enumerate(
            zip(rec.t_s.tolist(), rec.current_A.tolist(), rec.T_C.tolist(), rec.Q_W.tolist())
        )
    ]
    return write_text_atomic(path, "\n".join(lines) + "\n")


def record_slice(rec: Record, start: int, stop: int) -> Record:
    """Rows ``start:stop`` of a record (guard interventions are those of the whole record)."""
    rows = slice(start, stop)
    return Record(
        rec.t_s[rows],
        rec.current_A[rows],
        rec.T_C[rows],
        rec.Q_W[rows],
        rec.T_sink_C[rows],
        rec.Q_true_W[rows],
        guard_interventions=rec.guard_interventions,
    )


def fit_experiment(
    rec: Record,
    *,
    plan: IdentifyPlan,
    orders: NarmaOrders = NarmaOrders(),
    period_s: float,
    settings: ExperimentSettings = ExperimentSettings(),
    method: str = "oe",
    meta: dict[str, Any] | None = None,
    keep_record: bool = False,
    source: str = "telethermo.ident.experiment.identify_rig",
) -> tuple[TemModel, dict[str, Any]]:
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
    model = fit_narma(
        current_A=fit_rec.current_A,
        T_C=fit_rec.T_C,
        orders=orders,
        period_s=float(period_s),
        T_ref_C=T_ref,
        method=method,
    )
    t_fit = time.perf_counter() - t1
    fr = model.free_run(current_A=allrec.current_A, T0_C=T_ref)
    metrics = _add_heldout_metrics(model, allrec, fr, n_fit, plan.validation_samples)
    stab = check_stability(model)

    t2 = time.perf_counter()
    flux = _fit_flux(fit_rec, settings, float(period_s), T_ref)
    t_flux = time.perf_counter() - t2
    fmetrics = _add_flux_heldout_metrics(flux, allrec, n_fit)

    report: dict[str, Any] = {
        "orders": orders.as_dict(),
        "period_s": float(period_s),
        "seed": int(plan.seed),
        "n_train": int(plan.train_samples),
        "n_validation": int(plan.validation_samples),
        "rest_samples": n_rest,
        "T_ref_C": T_ref,
        "rest_drift_C": _rest_drift(rest_T),
        "heldout_free_run_max_C": metrics["heldout_free_run_max_C"],
        "heldout_free_run_rms_C": metrics["heldout_free_run_rms_C"],
        "heldout_one_step_max_C": metrics["heldout_one_step_max_C"],
        "train_one_step_rms_C": metrics["rms_one_step_C"],
        "flux_heldout_max_W": fmetrics["heldout_free_run_max_W"],
        "flux_heldout_rms_W": fmetrics["heldout_free_run_rms_W"],
        "flux_with_current": flux.with_current,
        "stable": stab.stable,
        "stability_reason": stab.reason,
        "max_pole_modulus": stab.max_pole_modulus,
        "stability_free_run_max_dev_C": stab.free_run_max_dev_C,
        "guard_interventions": allrec.guard_interventions,
        "current_range_A": list(model.current_range_A),
        "T_range_C": [float(allrec.T_C.min()), float(allrec.T_C.max())],
        "experiment_wall_s": math.nan,
        "fit_wall_s": t_fit,
        "flux_fit_wall_s": t_flux,
        "fit_method": method,
        "settings": asdict(settings),
        "plan": plan.as_dict(),
    }
    if keep_record:
        report["record"] = _record_arrays(allrec, fr, flux, n_fit)
    tem_meta = _model_meta(source, plan, settings, meta)
    return TemModel(temperature=model, flux=flux, capacity=None, meta=tem_meta), report


def _add_heldout_metrics(
    model: NarmaModel, rec: Record, free_run_C: np.ndarray, n_fit: int, n_heldout: int
) -> dict[str, Any]:
    """The model's metrics with its held-out free-run and one-step errors, °C, on ``rec`` from sample
    ``n_fit`` on (``free_run_C``: its free run over the whole record); set on the model and returned."""
    e_val = (free_run_C - rec.T_C)[n_fit:]
    os_ = model.predict_one_step(current_A=rec.current_A, T_C=rec.T_C)
    e_os = (os_ - rec.T_C)[n_fit:]
    metrics = dict(model.metrics)
    metrics.update(
        {
            "heldout_free_run_max_C": float(np.max(np.abs(e_val))),
            "heldout_free_run_rms_C": float(np.sqrt(np.mean(e_val**2))),
            "heldout_one_step_max_C": float(np.max(np.abs(e_os))),
            "heldout_one_step_rms_C": float(np.sqrt(np.mean(e_os**2))),
            "heldout_samples": int(n_heldout),
        }
    )
    object.__setattr__(model, "metrics", metrics)
    return metrics


def _fit_flux(fit_rec: Record, settings: ExperimentSettings, period_s: float, T_ref: float) -> FluxArma:
    """The heat-flux model (eq. 12) of the training part; ``period_s``: s, ``T_ref``: °C."""
    fn, fm = settings.flux_orders
    return fit_flux_arma(
        T_C=fit_rec.T_C,
        Q_W=fit_rec.Q_W,
        n=fn,
        m=fm,
        period_s=period_s,
        T_ref_C=T_ref,
        current_A=fit_rec.current_A if settings.flux_with_current else None,
    )


def _add_flux_heldout_metrics(flux: FluxArma, rec: Record, n_fit: int) -> dict[str, Any]:
    """The flux model's metrics with its held-out free-run errors, W; set on the model and returned."""
    fe = flux.errors(T_C=rec.T_C, Q_W=rec.Q_W, current_A=rec.current_A, start=n_fit)
    fmetrics = dict(flux.metrics)
    fmetrics.update(
        {"heldout_free_run_max_W": fe["free_run_max_W"], "heldout_free_run_rms_W": fe["free_run_rms_W"]}
    )
    object.__setattr__(flux, "metrics", fmetrics)
    return fmetrics


def _record_arrays(rec: Record, free_run_C: np.ndarray, flux: FluxArma, n_fit: int) -> dict[str, Any]:
    """The record with the two models' free runs (°C, W), for the report's ``record``."""
    return {
        "t_s": rec.t_s,
        "current_A": rec.current_A,
        "T_C": rec.T_C,
        "Q_W": rec.Q_W,
        "T_pred_C": free_run_C,
        "Q_pred_W": flux.free_run(T_C=rec.T_C, current_A=rec.current_A),
        "n_fit": n_fit,
    }


def _model_meta(
    source: str, plan: IdentifyPlan, settings: ExperimentSettings, meta: dict[str, Any] | None
) -> dict[str, Any]:
    """The model file's ``meta``: the experiment's provenance, then ``meta``."""
    tem_meta = {
        "source": source,
        "seed": int(plan.seed),
        "n_train": int(plan.train_samples),
        "n_validation": int(plan.validation_samples),
        "settings": asdict(settings),
    }
    tem_meta.update(meta or {})
    return tem_meta
