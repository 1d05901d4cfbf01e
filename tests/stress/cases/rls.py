"""Stress cases of the streaming RLS (telethermo.ident.rls.Rls): poor excitation, conditioning, λ bounds,
signal scales, non-finite samples.

Every case identifies a known linear regression y = θ*ᵀφ + noise (d = 6, noise σ = 0.01), so each
figure can be judged against the truth θ*.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from tests.stress.cases.case import Case
from telethermo.ident import Rls

D = 6
THETA = np.array([0.8, -0.3, 1.5, 0.05, -2.0, 0.6])
SIGMA = 0.01
COND_MAX = 1e12  # beyond ~1e12 a double-precision K loses its smallest eigen-directions (eps·cond ~ 1e-4)


def _run(r: Rls, Phi: np.ndarray, y: np.ndarray, *, watch_every: int = 0) -> dict:
    """Feed samples; return θ finiteness, per-sample |Δθ| max and (if watch_every) the health extremes."""
    out = {"theta_finite": True, "max_step": 0.0, "max_trace": 0.0, "max_cond": 0.0, "min_eig": math.inf}
    prev = r.theta
    steps = np.empty(len(y))
    for k in range(len(y)):
        r.update(Phi[k], y[k])
        th = r.theta
        if not np.all(np.isfinite(th)):
            out["theta_finite"] = False
        steps[k] = float(np.linalg.norm(th - prev))
        prev = th
        if watch_every and (k + 1) % watch_every == 0:
            h = r.health()
            out["max_trace"] = max(out["max_trace"], h.trace)
            out["max_cond"] = max(out["max_cond"], h.condition)
            out["min_eig"] = min(out["min_eig"], h.min_eig)
    out["steps"] = steps
    out["max_step"] = float(np.max(steps)) if len(steps) else 0.0
    return out


def _excitation(rng: np.random.Generator, n: int, theta: np.ndarray = THETA) -> tuple[np.ndarray, np.ndarray]:
    Phi = rng.normal(size=(n, D))
    return Phi, Phi @ theta + SIGMA * rng.normal(size=n)


def _samples_to(r_path: np.ndarray, target: np.ndarray, tol: float) -> int:
    """First sample index after which ‖θ - target‖ stays <= tol (len if never)."""
    err = np.linalg.norm(r_path - target, axis=1)
    bad = np.flatnonzero(err > tol)
    return 0 if bad.size == 0 else int(bad[-1] + 1)


def _step_phase(r: Rls, Phi_s: np.ndarray, y_s: np.ndarray, theta_new: np.ndarray) -> dict:
    """Excitation returns with θ* stepped: the largest per-sample jump of θ and the samples to within 1 %."""
    path = np.empty((len(y_s), D))
    res = {"max_step": 0.0, "finite": True}
    prev = r.theta
    for k in range(len(y_s)):
        r.update(Phi_s[k], y_s[k])
        path[k] = r.theta
        res["finite"] &= bool(np.all(np.isfinite(path[k])))
        res["max_step"] = max(res["max_step"], float(np.linalg.norm(path[k] - prev)))
        prev = path[k]
    res["to_1pct"] = _samples_to(path, theta_new, 0.01 * np.linalg.norm(theta_new))
    return res


def _idle_variant(c: Case, variant: str, rng, n_idle: int, phases: dict, ref_step: dict, kw: dict) -> None:
    """One idle hour (φ = 0, or φ stuck in one direction) then the step, with its figures and requirements."""
    Phi_a, y_a, Phi_s, y_s, theta_new, delta, direction = (
        phases[k] for k in ("Phi_a", "y_a", "Phi_s", "y_s", "theta_new", "delta", "direction")
    )
    r = Rls(D, **kw)
    _run(r, Phi_a, y_a)
    th_a = r.theta
    if variant == "zero":
        Phi_i = np.zeros((n_idle, D))
        y_i = SIGMA * rng.normal(size=n_idle)
    else:
        Phi_i = direction + 1e-6 * rng.normal(size=(n_idle, D))
        y_i = Phi_i @ THETA + SIGMA * rng.normal(size=n_idle)
    idle = _run(r, Phi_i, y_i, watch_every=max(n_idle // 36, 1))
    drift = float(np.linalg.norm(r.theta - th_a))
    st = _step_phase(r, Phi_s, y_s, theta_new)
    h = r.health()
    p = f"{variant}_"
    c.fig(
        **{
            p + "idle_max_trace": idle["max_trace"],
            p + "trace_max": r.trace_max,
            p + "idle_max_cond": idle["max_cond"],
            p + "idle_min_eig": idle["min_eig"],
            p + "idle_theta_drift": drift,
            p + "step_max_jump": st["max_step"],
            p + "samples_to_1pct": st["to_1pct"],
            p + "trace_capped": h.n_trace_capped,
            p + "numerical_failures": h.n_numerical_failures,
        }
    )
    c.require(idle["theta_finite"] and st["finite"], f"{variant}: θ stayed finite")
    c.require(
        idle["max_trace"] <= r.trace_max * (1 + 1e-9),
        f"{variant}: tr K {idle['max_trace']:.6g} <= trace_max {r.trace_max:.6g}",
    )
    c.require(idle["max_cond"] <= COND_MAX, f"{variant}: cond K {idle['max_cond']:.3g} <= {COND_MAX:g}")
    c.require(
        drift <= 0.05 * np.linalg.norm(THETA), f"{variant}: θ drift while idle {drift:.3g} <= 5 % of ‖θ*‖"
    )
    c.require(
        st["max_step"] <= 1.5 * np.linalg.norm(delta),
        f"{variant}: max per-sample jump {st['max_step']:.3g} <= 1.5 × step {np.linalg.norm(delta):.3g}",
    )
    c.require(
        st["to_1pct"] < len(y_s) and st["to_1pct"] <= 4 * ref_step["to_1pct"],
        f"{variant}: re-convergence {st['to_1pct']} samples <= 4 × never-idle {ref_step['to_1pct']}",
    )
    if variant == "stuck" and st["to_1pct"] > 1.5 * ref_step["to_1pct"]:
        c.note(
            f"stuck: re-convergence took {st['to_1pct']} samples vs {ref_step['to_1pct']} never idle: while "
            "the "
            "trace is capped, the constant-trace scaling cancels the forgetting in the one excited "
            "direction, "
            f"so information there keeps accumulating (min eig of K {idle['min_eig']:.2g}) and has to be "
            "forgotten again when excitation returns; the delay grows with the log of the idle time. "
            "Directional forgetting would not have it (see telethermo/ident/rls.py's choice)."
        )


def case_idle_hour_then_step(n_idle: int = 360_000, seed: int = 1) -> dict:
    """1 hour of samples (at 0.01 s) with no excitation, then excitation returns with a parameter step."""
    c = Case(
        "rls_idle_hour_then_step",
        f"λ1 = 0.999, K(0) = 100·I: through {n_idle} samples without excitation (φ = 0, and φ stuck in one "
        f"direction) tr K stays <= trace_max, cond K <= {COND_MAX:g}, θ finite and does not drift; when "
        "excitation returns with a step of θ*, no per-sample jump of θ larger than 1.5× the step itself, "
        "and re-convergence to 1 % no slower than 4× a never-idle estimator",
    )
    rng = np.random.default_rng(seed)
    Phi_a, y_a = _excitation(rng, 5000)
    delta = np.full(D, 0.2)
    theta_new = THETA + delta
    Phi_s, y_s = _excitation(rng, 15_000, theta_new)
    direction = rng.normal(size=D)
    direction /= np.linalg.norm(direction)
    kw = dict(lambda1=0.999, K0=100.0)
    phases = {
        "Phi_a": Phi_a,
        "y_a": y_a,
        "Phi_s": Phi_s,
        "y_s": y_s,
        "theta_new": theta_new,
        "delta": delta,
        "direction": direction,
    }

    ref = Rls(D, **kw)
    _run(ref, Phi_a, y_a)
    ref_step = _step_phase(ref, Phi_s, y_s, theta_new)
    c.fig(
        step_norm=float(np.linalg.norm(delta)),
        never_idle_max_jump=ref_step["max_step"],
        never_idle_samples_to_1pct=ref_step["to_1pct"],
    )
    for variant in ("zero", "stuck"):
        _idle_variant(c, variant, rng, n_idle, phases, ref_step, kw)

    # what the guard prevents: the same idle period without the constant-trace bound
    r = Rls(D, trace_max=math.inf, **kw)
    _run(r, Phi_a, y_a)
    _run(r, np.zeros((n_idle, D)), SIGMA * rng.normal(size=n_idle))
    tr_unguarded = r.health().trace
    st = _step_phase(r, Phi_s, y_s, theta_new)
    c.fig(
        unguarded_trace_after_idle=tr_unguarded,
        unguarded_numerical_failures=r.n_numerical_failures,
        unguarded_step_max_jump=st["max_step"],
    )
    c.note(
        "unguarded_* = the same estimator with trace_max = inf (no constant-trace bound), for comparison only"
    )
    return c.result()


def case_collinear(n: int = 20_000, seed: int = 2) -> dict:
    """Exactly and nearly collinear columns and columns 1e6 apart in scale."""
    c = Case(
        "rls_ill_conditioned_collinear",
        "regressors with an exact copy, a 1e-9 near-copy and columns scaled 1e3 and 1e-3: K stays positive "
        "semi-definite with tr K <= trace_max, θ finite, the fit residual on the second half <= 1.2 σ and "
        "the "
        "predictions equal batch least squares (lstsq) within 0.1 σ RMS",
    )
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(n, D))
    x[:, 1] = x[:, 0]
    x[:, 2] = x[:, 0] + 1e-9 * rng.normal(size=n)
    x[:, 3] *= 1e3
    x[:, 4] *= 1e-3
    theta = np.array([0.5, 0.5, -0.2, 1e-3, 300.0, 0.7])
    y = x @ theta + SIGMA * rng.normal(size=n)
    cond_data = float(np.linalg.cond(x))
    c.fig(cond_regressors=cond_data)
    for lam in (1.0, 0.999):
        r = Rls(D, lambda1=lam, K0=1e6)
        run = _run(r, x, y, watch_every=n // 10)
        h = r.health()
        pred = x @ r.theta
        half = slice(n // 2, n)
        resid = float(np.sqrt(np.mean((y[half] - pred[half]) ** 2)))
        th_ls, *_ = np.linalg.lstsq(x, y, rcond=None)
        diff = float(np.sqrt(np.mean((x[half] @ th_ls - pred[half]) ** 2)))
        p = f"lambda1_{lam:g}_"
        c.fig(
            **{
                p + "residual_rms": resid,
                p + "vs_lstsq_rms": diff,
                p + "max_cond_K": run["max_cond"],
                p + "min_eig_K": run["min_eig"],
                p + "numerical_failures": h.n_numerical_failures,
            }
        )
        c.require(run["theta_finite"], f"λ1 = {lam}: θ finite")
        c.require(
            run["min_eig"] >= 0.0, f"λ1 = {lam}: K positive semi-definite (min eig {run['min_eig']:.3g})"
        )
        c.require(
            run["max_trace"] <= r.trace_max * (1 + 1e-9), f"λ1 = {lam}: tr K {run['max_trace']:.4g} bounded"
        )
        c.require(resid <= 1.2 * SIGMA, f"λ1 = {lam}: residual {resid:.4g} <= 1.2 σ = {1.2 * SIGMA}")
        if lam == 1.0:
            c.require(diff <= 0.1 * SIGMA, f"λ1 = 1: predictions vs lstsq {diff:.3g} <= 0.1 σ")
    return c.result()


def case_lambda_bounds(n: int = 20_000, seed: int = 3) -> dict:
    """λ1, λ2 just inside their bounds run safely; values outside are refused."""
    c = Case(
        "rls_lambda_near_bounds",
        "λ1 in (0, 1] and λ2 in (0, 2): values outside (and NaN/inf) are refused with a ValueError naming "
        "the "
        "factor; values just inside run with θ finite and tr K <= trace_max, and converge within 0.05 of θ* "
        "whenever the memory 1/(1-λ1) exceeds 10 samples and λ2 >= 0.5",
    )
    refused = []
    for kw in (
        {"lambda1": 0.0},
        {"lambda1": -0.1},
        {"lambda1": 1.0 + 1e-12},
        {"lambda1": math.nan},
        {"lambda1": math.inf},
        {"lambda2": 0.0},
        {"lambda2": 2.0},
        {"lambda2": math.nan},
    ):
        name = next(iter(kw))
        try:
            Rls(D, **kw)
            c.require(False, f"Rls({kw}) refused")
        except ValueError as exc:
            c.require(name in str(exc), f"the error for {kw} names {name}: {exc}")
            refused.append(str(kw))
    c.fig(refused=refused)
    rng = np.random.default_rng(seed)
    Phi, y = _excitation(rng, n)
    for l1, l2 in (
        (1.0 - 1e-12, 1.0),
        (0.999999, 1.0),
        (0.9, 1.0),
        (0.5, 1.0),
        (1e-3, 1.0),
        (0.99, 1e-6),
        (0.99, 2.0 - 1e-6),
        (1.0 - 1e-12, 2.0 - 1e-6),
    ):
        r = Rls(D, lambda1=l1, lambda2=l2, K0=100.0)
        run = _run(r, Phi, y, watch_every=n // 4)
        err = float(np.linalg.norm(r.theta - THETA))
        p = f"l1_{l1:.12g}_l2_{l2:.7g}_"
        c.fig(**{p + "theta_error": err, p + "max_trace": run["max_trace"], p + "max_cond": run["max_cond"]})
        c.require(run["theta_finite"], f"λ1 = {l1}, λ2 = {l2}: θ finite")
        c.require(run["max_trace"] <= r.trace_max * (1 + 1e-9), f"λ1 = {l1}, λ2 = {l2}: tr K bounded")
        if 1.0 / max(1.0 - l1, 1e-300) > 10 and l2 >= 0.5:
            c.require(err <= 0.05, f"λ1 = {l1}, λ2 = {l2}: ‖θ - θ*‖ = {err:.3g} <= 0.05")
    return c.result()


def case_signal_scales(n: int = 20_000, seed: int = 4) -> dict:
    """Signals of 1e6 and 1e-6 (and columns 1e12 apart), with and without the ``scale`` option."""
    c = Case(
        "rls_signal_scales",
        "φ and y at scales 1e6 and 1e-6 and a φ whose columns span 1e-6..1e6: θ finite, tr K bounded, no "
        "numerical failure; with the documented per-column `scale` option θ converges within 1 % of θ*",
    )
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(n, D))
    noise = SIGMA * rng.normal(size=n)
    mixed = np.array([1e-6, 1e-3, 1.0, 1e3, 1e6, 1.0])
    for label, s in (("1e6", np.full(D, 1e6)), ("1e-6", np.full(D, 1e-6)), ("mixed", mixed)):
        Phi = x * s
        theta = THETA / s  # each column contributes O(1) to y: every parameter matters
        y = Phi @ theta + noise
        for use_scale in (False, True):
            r = Rls(D, lambda1=0.9999, scale=s if use_scale else None)
            run = _run(r, Phi, y, watch_every=n // 4)
            rel = float(np.max(np.abs(r.theta - theta) / np.abs(theta)))
            p = f"{label}_{'scaled' if use_scale else 'raw'}_"
            c.fig(
                **{
                    p + "max_rel_theta_error": rel,
                    p + "numerical_failures": r.n_numerical_failures,
                    p + "max_trace": run["max_trace"],
                }
            )
            c.require(run["theta_finite"], f"{label} scale={use_scale}: θ finite")
            c.require(
                run["max_trace"] <= r.trace_max * (1 + 1e-9), f"{label} scale={use_scale}: tr K bounded"
            )
            c.require(
                r.n_numerical_failures == 0,
                f"{label} scale={use_scale}: numerical failures {r.n_numerical_failures} == 0",
            )
            if use_scale:
                c.require(rel <= 0.01, f"{label} with scale: max relative θ error {rel:.3g} <= 1 %")
    c.note(
        "raw (no `scale`): K(0) = 1e4·I is the prior for unit-size regressors; at 1e-6 the gain φᵀKφ ~ 1e-8 "
        "makes learning negligibly slow (max_rel_theta_error ~ 1). Give `scale` (or a matched K0) for such "
        "signals."
    )
    return c.result()


def case_nonfinite_bursts(n: int = 20_000, seed: int = 5) -> dict:
    """NaN/inf bursts are rejected and counted and change nothing; overflowing finite samples are survived."""
    c = Case(
        "rls_nonfinite_bursts",
        "bursts of NaN/±inf in φ or y are rejected, counted exactly, and leave θ and K bit-identical to a "
        "run "
        "without them; finite samples up to 1e300 that overflow the update leave θ and K finite (counted as "
        "numerical failures or rejections) with no parameter jump; with a trace floor (trace_min) the "
        "estimate "
        "still converges within 0.05",
    )
    rng = np.random.default_rng(seed)
    Phi, y = _excitation(rng, n)
    bad = np.zeros(n, dtype=bool)
    Phi_b, y_b = Phi.copy(), y.copy()
    for _ in range(60):
        k0 = int(rng.integers(0, n - 60))
        L = int(rng.integers(1, 51))
        kind = int(rng.integers(0, 4))
        sl = slice(k0, k0 + L)
        bad[sl] = True
        if kind == 0:
            Phi_b[sl, int(rng.integers(0, D))] = np.nan
        elif kind == 1:
            Phi_b[sl, int(rng.integers(0, D))] = np.inf * rng.choice([-1, 1])
        elif kind == 2:
            y_b[sl] = np.nan
        else:
            y_b[sl] = -np.inf
    a, b = Rls(D, lambda1=0.999), Rls(D, lambda1=0.999)
    run = _run(a, Phi_b, y_b)
    _run(b, Phi[~bad], y[~bad])
    n_bad = int(bad.sum())
    c.fig(injected_nonfinite=n_bad, rejected_counted=a.n_rejected_nonfinite)
    c.require(run["theta_finite"], "θ finite through the bursts")
    c.require(a.n_rejected_nonfinite == n_bad, f"rejected {a.n_rejected_nonfinite} == injected {n_bad}")
    c.require(
        np.array_equal(a.theta, b.theta) and np.array_equal(a.K, b.K),
        "θ and K bit-identical to the run without the bad samples "
        f"(max |Δθ| {float(np.max(np.abs(a.theta - b.theta))):.3g})",
    )
    # finite but huge samples: magnitudes 1e10, 1e20, ... (up to 1e300 when n allows), each a consistent
    # sample
    # (y = θ*ᵀφ + noise, all scaled): no reason for θ to move. Default estimator and one with a trace floor.
    for label, kw in (("huge_default", {}), ("huge_trace_min", {"trace_min": 1e-4 * D * 1e4})):
        r = Rls(D, lambda1=0.999, **kw)
        worst_theta = 0.0
        mags = [10.0**k for k in range(10, 301, 10)]
        used = 0
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            for k in range(n):
                if k % 500 == 250 and mags:
                    m = mags.pop(0)
                    r.update(Phi[k] * m, y[k] * m)
                    used += 1
                else:
                    r.update(Phi[k], y[k])
                if k >= 250:  # after the first huge sample (the start-up transient is not the point)
                    worst_theta = max(worst_theta, float(np.max(np.abs(r.theta))))
        err = float(np.linalg.norm(r.theta - THETA))
        h = r.health()
        p = label + "_"
        c.fig(
            **{
                p + "samples": used,
                p + "max_magnitude": 10.0 ** (10 * used),
                p + "numerical_failures": h.n_numerical_failures,
                p + "max_abs_theta": worst_theta,
                p + "final_theta_error": err,
                p + "final_trace": h.trace,
                p + "runtime_warnings": len(caught),
            }
        )
        c.require(math.isfinite(worst_theta) and np.all(np.isfinite(r.K)), f"{label}: θ and K finite")
        c.require(
            worst_theta <= 1.5 * float(np.max(np.abs(THETA))),
            f"{label}: no parameter jump on consistent huge samples: max |θ| {worst_theta:.3g} <= 1.5 max "
            "|θ*|",
        )
        if kw:
            c.require(err <= 0.05, f"{label}: ‖θ - θ*‖ after the huge samples {err:.3g} <= 0.05")
        elif h.trace < 1e-12:
            c.note(
                "FINDING (telethermo/ident/rls.py, default trace_min = 0): consistent samples of magnitude "
                "up to "
                f"1e{10 * used} collapse K to tr K = {h.trace:.2g} (every direction informed by ~1e200): the "
                f"estimator is frozen (‖θ - θ*‖ = {err:.3g} at the end) until forgetting regrows K, "
                "~ln(1/trK)/"
                "(1-λ1) samples; only a covariance reset or a trace floor (trace_min) recovers it. A "
                "plausibility "
                "bound on |φ| or a default trace_min would."
            )
        if caught:
            c.note(
                f"{label}: {len(caught)} numpy RuntimeWarnings (overflow in the update's products) for "
                "samples of "
                "1e160..1e300; the update catches the non-finite result, the warnings are only noise"
            )
    return c.result()


CASES = {
    "rls_idle_hour_then_step": (case_idle_hour_then_step, {"n_idle": 360_000}, {"n_idle": 120_000}),
    "rls_ill_conditioned_collinear": (case_collinear, {}, {}),
    "rls_lambda_near_bounds": (case_lambda_bounds, {}, {"n": 10_000}),
    "rls_signal_scales": (case_signal_scales, {}, {"n": 10_000}),
    "rls_nonfinite_bursts": (case_nonfinite_bursts, {}, {}),
}
"""name -> (function, full-run kwargs, --quick kwargs)"""
