"""``telethermo identify``'s report: every line's value starts in the same column, the gain lines and the
max-cooling-current line included (they were one column left and one right of the others)."""

from __future__ import annotations

from telethermo.cli.identify_output import LABEL_WIDTH, print_report
from telethermo.ident import default_model_path, load_model

REP = {
    "orders": {"n": 4, "m": 4, "p": 1, "q": 1},
    "fit_method": "oe",
    "n_train": 400,
    "n_validation": 100,
    "period_s": 0.01,
    "T_ref_C": 25.0,
    "rest_drift_C": -0.003,
    "heldout_free_run_max_C": 0.15,
    "heldout_free_run_rms_C": 0.11,
    "heldout_one_step_max_C": 0.007,
    "flux_heldout_max_W": 0.001,
    "flux_heldout_rms_W": 0.0007,
    "flux_with_current": True,
    "stable": True,
    "stability_reason": "",
    "max_pole_modulus": 0.9995,
    "guard_interventions": 0,
    "T_range_C": (22.9, 26.2),
    "current_range_A": (-0.94, 0.88),
    "experiment_wall_s": 0.01,
    "fit_wall_s": 0.07,
    "capacity_points": 14,
    "capacity_current_range_A": (-1.0, 1.0),
    "capacity_max_abs_W": 1e-3,
}


def test_every_report_line_has_its_value_in_the_same_column(capsys):
    print_report(REP, load_model(default_model_path()), ("master", "slave"))
    lines = capsys.readouterr().out.splitlines()
    labels = [line[:LABEL_WIDTH].rstrip() for line in lines]
    assert {"gains (master)", "gains (slave)", "max cooling current", "orders n,m,p,q"} <= set(labels)
    for line in lines:
        label, value = line[:LABEL_WIDTH], line[LABEL_WIDTH:]
        assert label.rstrip() and label.endswith("  ") and not value.startswith(" "), repr(line)
