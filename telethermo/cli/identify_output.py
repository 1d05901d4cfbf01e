"""What ``telethermo identify`` prints, on a simulated rig or a live node: the report of the fit (the
experiment's progress is :class:`telethermo.cli.progress.Progress`)."""

from __future__ import annotations

from telethermo.control.gain_rule import MIN_GAIN_MARGIN_DB, MIN_PHASE_MARGIN_DEG, fit_gains
from telethermo.control.types import Role

#: width of the report's label column: every value starts in the same column
LABEL_WIDTH = 26


def _row(label: str, value: str) -> str:
    return f"{label:<{LABEL_WIDTH}}{value}"


def gain_lines(model, roles: tuple[str, ...]) -> list[str]:
    """What the node will run on this model: the gain rule's factor and the loop's margins on the model
    (telethermo.control.gain_rule), one line per role."""
    out = []
    for role in roles:
        fit = fit_gains(model, Role[role.upper()])
        m = fit["margins"]
        ok = "meets" if fit["meets_minimum"] else "BELOW"
        out.append(
            _row(
                f"gains ({role})",
                f"x{fit['rho']:.3f} of the shipped; on this model gain margin "
                f"{m['gain_margin_dB']:.1f} dB, phase margin {m['phase_margin_deg']:.1f}°, crossover "
                f"{m['crossover_Hz']:.2f} Hz ({ok} the minimum {MIN_GAIN_MARGIN_DB:g} dB / "
                f"{MIN_PHASE_MARGIN_DEG:g}°)",
            )
        )
    if not roles:
        return out
    cool = fit_gains(model, Role[roles[0].upper()])["max_cooling_A"]
    what = (
        "not found in the model's range (no limit beyond the drive's)"
        if cool is None
        else f"{cool:.2f} A (beyond it the Joule heat wins: the node holds its cooling current there)"
    )
    out.append(_row("max cooling current", what))
    return out


def print_report(rep: dict, model=None, roles: tuple[str, ...] = ()) -> None:
    o = rep["orders"]
    lines = [
        f"orders n,m,p,q            {o['n']},{o['m']},{o['p']},{o['q']}  (fit: {rep['fit_method']})",
        f"samples                   {rep['n_train']} training + {rep['n_validation']} held-out at "
        f"{rep['period_s']} s",
        f"reference temperature     {rep['T_ref_C']:.3f} °C (drift over the rest samples "
        f"{rep['rest_drift_C']:+.4f} °C{'' if abs(rep['rest_drift_C']) < 0.05 else ': NOT AT REST'})",
        f"held-out free run         worst {rep['heldout_free_run_max_C']:.4f} °C, "
        f"rms {rep['heldout_free_run_rms_C']:.4f} °C",
        f"held-out one-step         worst {rep['heldout_one_step_max_C']:.4f} °C",
        f"heat flux (held-out)      worst {rep['flux_heldout_max_W']:.4f} W, "
        f"rms {rep['flux_heldout_rms_W']:.4f} W"
        f"{' (with current terms)' if rep['flux_with_current'] else ''}",
        f"stability                 {'stable' if rep['stable'] else 'UNSTABLE: ' + rep['stability_reason']}, "
        f"max local pole |z| = {rep['max_pole_modulus']:.6f}",
        f"safety guard              {rep['guard_interventions']} interventions; T {rep['T_range_C'][0]:.2f}.."
        f"{rep['T_range_C'][1]:.2f} °C, "
        f"I {rep['current_range_A'][0]:+.2f}..{rep['current_range_A'][1]:+.2f} A",
        f"time                      experiment {rep['experiment_wall_s']:.2f} s, "
        f"fit {rep['fit_wall_s']:.2f} s",
    ]
    if "capacity_points" in rep:
        lines.append(
            f"capacity (eq. 13)         {rep['capacity_points']} steady states, I "
            f"{rep['capacity_current_range_A'][0]:+.3f}..{rep['capacity_current_range_A'][1]:+.3f} A, "
            f"fit residual max {rep['capacity_max_abs_W']:.2e} W"
        )
    if model is not None and rep.get("stable", True):
        lines += gain_lines(model, roles)
    print("\n".join(lines))
