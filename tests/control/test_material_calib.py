"""The calibrated material classifier (telethermo/control/material_calib.py): its file, its errors, its
physics."""

from __future__ import annotations

import json
import math
import zipfile
from dataclasses import replace

import numpy as np
import pytest

from telethermo.offline.material_calibration import calibrate
from telethermo.offline.material_touches import (
    CALIBRATION,
    EVALUATION,
    HELDOUT,
    PERIOD_S,
    SIM_TO_TABLE,
    finger_natural_C,
    refuse_overlap,
    simulate_touch,
)
from telethermo.control import material_id as mi
from telethermo.control.material_calib import (
    DEFAULT_CALIBRATION,
    classify_vector,
    load_calibration,
    n_units,
    save_calibration,
    touch_vector,
    whitener,
)
from telethermo.control.material_stream import (
    UNITS_PER_CYCLE,
    UNKNOWN_CODE,
    MaterialIdParams,
    MaterialState,
    calibrated,
    default_classes,
    early_samples,
    fit_units,
    fit_work_units,
    material_step,
)
from telethermo.control.material_train import TrainSettings
from telethermo.control.params import default_params
from telethermo.control.types import Role
from telethermo.sim.measurement import NoiseParams
from telethermo.sim.tem import load_rig_params

PARAMS = load_rig_params()
CAL = load_calibration()


def test_shipped_calibration_round_trips(tmp_path):
    out = save_calibration(CAL, tmp_path / "c.npz")
    back = load_calibration(out)
    assert back.classes == CAL.classes and back.dt_s == CAL.dt_s and back.n_win == CAL.n_win
    assert back.scale == CAL.scale and back.info == CAL.info and len(back.nets) == len(CAL.nets)
    for name in ("center", "whiten"):
        assert np.array_equal(getattr(back, name), getattr(CAL, name)), name
    for net_b, net in zip(back.nets, CAL.nets):
        assert all(np.array_equal(a, b) for la, lb in zip(net_b, net) for a, b in zip(la, lb))
    assert not list(tmp_path.glob(".c.npz.*"))  # the temporary file was renamed


def _rewrite(src, dst, **change):
    """A copy of the calibration file ``src`` with fields replaced (None: removed)."""
    with np.load(src, allow_pickle=False) as d:
        fields = {k: d[k] for k in d.files}
    for k, v in change.items():
        if v is None:
            fields.pop(k)
        else:
            fields[k] = v
    np.savez(dst, **fields)
    return dst


@pytest.mark.parametrize(
    "change, field",
    [
        ({"net0_w1": None}, "net0_w1"),
        ({"scale": np.array(-1.0)}, "scale"),
        ({"n_nets": np.array(0)}, "n_nets"),
        ({"net0_w0": np.zeros((7, 3), np.float32)}, "net0_w0"),
        ({"center": np.zeros(7)}, "center"),
        ({"format": np.array("something else")}, "format"),
        ({"whiten": np.full((60, 60), np.nan)}, "whiten"),
    ],
)
def test_malformed_file_gives_one_line_error_naming_file_and_field(tmp_path, change, field):
    bad = _rewrite(DEFAULT_CALIBRATION, tmp_path / "bad.npz", **change)
    with pytest.raises(ValueError) as exc:
        load_calibration(bad)
    msg = str(exc.value)
    assert "\n" not in msg and str(bad) in msg and field in msg, msg


def test_a_file_that_is_no_archive_names_the_file(tmp_path):
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"PK\x03\x04 not really")
    with pytest.raises(ValueError) as exc:
        load_calibration(bad)
    assert str(bad) in str(exc.value) and "\n" not in str(exc.value)
    assert not zipfile.is_zipfile(bad)


def test_calibration_seeds_are_disjoint_from_the_evaluation_touches():
    info = json.loads(CAL.info)
    refuse_overlap(
        info["reference_touches"], (info["draw_seed"], info["sim_seed_first"])
    )  # raises if they meet
    assert (info["draw_seed"], info["sim_seed_first"]) == CALIBRATION
    dense = info["dense"]
    refuse_overlap(dense["touches"], (dense["draw_seed"], dense["sim_seed_first"]))
    with pytest.raises(ValueError, match="refused"):
        refuse_overlap(100, (EVALUATION[0] + 1, EVALUATION[1] + 50))
    with pytest.raises(ValueError, match="refused"):
        refuse_overlap(100, (HELDOUT[0], 10**7))


def test_classifier_names_thick_slabs_at_a_large_temperature_difference():
    """Ten materials, 20 mm slabs (semi-infinite within 0.3 s), 6 N, object 20 °C below the probe (ΔT ≈ 14
    °C),
    noise on, seeds no calibration touch used: at least 9 of the 10 are named right."""
    T_probe = finger_natural_C(PARAMS)
    names = [SIM_TO_TABLE[m] for m in SIM_TO_TABLE]
    right = 0
    for i, mat in enumerate(SIM_TO_TABLE):
        T, Q, i0, _, _ = simulate_touch(
            PARAMS, mat, 0.02, T_probe - 14.0, 6.0, T_probe, seed=900_000 + i, t_on_s=0.205
        )
        inp = mi.fit_input(T, Q, i0, PERIOD_S)
        got, post = classify_vector(CAL, touch_vector(inp, CAL.q_weight_K_per_W))
        right += CAL.classes[got] == names[i]
    assert right >= 9, right


@pytest.mark.parametrize("per_cycle", [1, UNITS_PER_CYCLE])
def test_the_core_publishes_the_calibrated_class_after_fit_units_cycles(per_cycle):
    """The staged fit (the physics fit's units, then one network layer per unit, ``per_cycle`` units a cycle)
    equals the batch one, published exactly fit_units cycles after the window."""
    T_probe = finger_natural_C(PARAMS)
    T, Q, i0, _, _ = simulate_touch(
        PARAMS, "glass", 0.02, T_probe - 12.0, 6.0, T_probe, seed=900_100, t_on_s=0.205
    )
    assert T.size > i0 + 30 + 20
    p = MaterialIdParams(units_per_cycle=per_cycle)
    work = fit_work_units(p, PERIOD_S)
    assert calibrated(p, PERIOD_S) and work == 3 + mi.noise_draws(p.probe) + n_units(CAL) == 15
    assert fit_units(p, PERIOD_S) == {1: 15, 3: 7}[per_cycle]  # 3 physics units a cycle, a layer a cycle
    n_win, units = early_samples(p, PERIOD_S), fit_units(p, PERIOD_S)  # the envelope classifier's window
    st = MaterialState()
    k_pub = i0 + n_win - 1 + units  # the window completes at i0 + n_win - 1
    for k in range(k_pub):
        st = material_step(p, st, T[k], Q[k], k >= i0, PERIOD_S)
        assert st.last.touch == 0
    st = material_step(p, st, T[k_pub], Q[k_pub], True, PERIOD_S)
    got, post = classify_vector(CAL, touch_vector(mi.fit_input(T, Q, i0, PERIOD_S), CAL.q_weight_K_per_W))
    codes = {name: code for code, name, _ in default_classes()}
    assert st.last.touch == 1 and st.last.code == codes[CAL.classes[got]]
    assert st.last.posterior == pytest.approx(post, rel=1e-12)
    assert st.last.effusivity == pytest.approx(mi.estimate_effusivity(T, Q, i0, PERIOD_S).b, rel=1e-12)


def test_another_period_falls_back_to_the_physics_classification():
    p = MaterialIdParams()
    assert not calibrated(p, 0.001) and fit_work_units(p, 0.001) == 4 + mi.noise_draws(p.probe)
    assert fit_units(p, 0.001) == -(-fit_work_units(p, 0.001) // p.units_per_cycle)


def test_whitener_maps_the_floored_noise_covariance_to_the_identity():
    rng = np.random.default_rng(3)
    A = rng.standard_normal((60, 60))
    S = A @ A.T * 1e-4 + np.diag(
        np.r_[np.full(30, 1e-12), np.full(30, 1e-6)]
    )  # nearly singular, like a filter's
    for reg in (0.0, 0.01):
        W = whitener(S, reg)
        floored = S + reg * np.mean(np.diag(S)) * np.eye(60)
        assert np.allclose(W @ floored @ W.T, np.eye(60), atol=1e-6)


def test_the_shipped_metric_is_in_units_of_the_rigs_noise():
    """The difference between a touch with the rig's noise and the same touch without it (seeds no calibration
    touch used), through the shipped calibration's whitening: each component's variance is at most about one
    (the whitening's floor only lowers it), and the largest is near one. A calibration in °C would give
    1e-4."""
    T_probe = finger_natural_C(PARAMS)
    mats = list(SIM_TO_TABLE)
    Z = []
    for i in range(120):
        mat, f, T_obj = (
            mats[i % 10],
            2.0 + 8.0 * ((i * 7) % 11) / 10.0,
            T_probe - 2.0 - 16.0 * ((i * 3) % 7) / 6.0,
        )
        T, Q, i0, _, _ = simulate_touch(
            PARAMS, mat, 0.005, T_obj, f, T_probe, seed=910_000 + i, t_on_s=0.203, identify=False
        )
        Tc, Qc, _, _, _ = simulate_touch(
            PARAMS,
            mat,
            0.005,
            T_obj,
            f,
            T_probe,
            seed=910_000 + i,
            t_on_s=0.203,
            noise=NoiseParams(enabled=False),
            identify=False,
        )
        v = touch_vector(mi.fit_input(T, Q, i0, PERIOD_S), CAL.q_weight_K_per_W)
        vc = touch_vector(mi.fit_input(Tc, Qc, i0, PERIOD_S), CAL.q_weight_K_per_W)
        Z.append(CAL.whiten @ (v - vc))
    var = np.var(np.array(Z), axis=0)
    assert var.max() < 1.6 and var.max() > 0.5, var  # 120 draws: a variance of 1 is estimated within ±0.4


def test_the_core_classifies_the_window_the_calibration_was_built_on():
    """The reference touches' windows start where the slave's contact detector says contact, as the core's
    own window does: the class the core publishes is the offline classification of that window."""
    T_probe = finger_natural_C(PARAMS)
    codes = {name: code for code, name, _ in default_classes()}
    for i, (mat, f) in enumerate((("brass", 3.0), ("pvc", 8.0))):
        T, Q, i0, est, _ = simulate_touch(
            PARAMS, mat, 0.004, T_probe - 9.0, f, T_probe, seed=920_000 + i, t_on_s=0.207
        )
        got, post = classify_vector(CAL, touch_vector(mi.fit_input(T, Q, i0, PERIOD_S), CAL.q_weight_K_per_W))
        assert est is not None and est.touch == 1 and est.code == codes[CAL.classes[got]]
        assert est.posterior == pytest.approx(post, rel=1e-12)


def test_a_touch_without_an_effusivity_is_published_unknown():
    """An object within 0.3 °C of the probe: neither form of the physics fit gives an effusivity (the batch
    fit says None); the in-box network would still name a class, but the evidence is weak (issue 23), so the
    slave publishes "unknown" with posterior 0 and a NaN effusivity, the touch counted (seeds no calibration
    touch used): with its envelope classifier (an early window without a fit) and without it (the physics
    posterior)."""
    T_probe = finger_natural_C(PARAMS)
    kw = dict(seed=950_053, t_on_s=0.2073)
    T, Q, i0, _, _ = simulate_touch(PARAMS, "glass", 0.001637, 33.909, 3.25, T_probe, **kw)
    assert abs(33.909 - T_probe) < 0.5 and mi.estimate_effusivity(T, Q, i0, PERIOD_S) is None
    assert (
        classify_vector(CAL, touch_vector(mi.fit_input(T, Q, i0, PERIOD_S), CAL.q_weight_K_per_W)) is not None
    )
    cp = default_params(Role.SLAVE, period_s=PERIOD_S)
    physics = replace(cp, material_id=replace(cp.material_id, envelope=None, envelope_late=None))
    for core in (cp, physics):
        _, _, _, est, _ = simulate_touch(
            PARAMS, "glass", 0.001637, 33.909, 3.25, T_probe, core_params=core, **kw
        )
        assert est is not None and est.touch == 1 and est.code == UNKNOWN_CODE and est.posterior == 0.0
        assert est.abstained in ("flux_reversed", "no_fit", "weak_evidence") and math.isnan(est.effusivity)


@pytest.mark.slow  # the calibration runs its touches in a process pool
def test_the_calibration_command_builds_a_classifier_the_slave_loads(tmp_path, capsys):
    """telethermo.offline.material_calibration (what bench.material_calibrate runs) end to end on a few
    touches (tiny networks): the file loads with the bench's classes and window, records its seeds, and a
    second run reads the cached touches instead of simulating."""
    small = TrainSettings(hidden=16, layers=1, epochs=2, n_nets=1)
    info = calibrate(40, tmp_path / "c.npz", 12, 1, small, tmp_path / "touches.npz", check=True)
    cal = load_calibration(tmp_path / "c.npz")
    assert cal.classes == CAL.classes and cal.n_win == CAL.n_win and cal.dt_s == CAL.dt_s
    assert json.loads(cal.info)["references_kept"] == info["references_kept"] == 52
    assert 0.0 <= info["validation_accuracy"] <= 1.0
    capsys.readouterr()
    calibrate(40, tmp_path / "c2.npz", 12, 1, small, tmp_path / "touches.npz")
    assert "read from" in capsys.readouterr().out
    assert np.array_equal(load_calibration(tmp_path / "c2.npz").center, cal.center)
