"""A lab's calibration of the physics fit (issue 23; telethermo.control.material_lab): the fit recovers a
known correction, the identity leaves the slave's answer unchanged to the last digit, a correction reaches
the published effusivity and posterior through the slave's core, and the lab file refuses bad fields."""

from __future__ import annotations

import json
import math
import re
from dataclasses import replace

import numpy as np
import pytest

from telethermo.control import material_lab as ml
from telethermo.control import material_physics as mp
from telethermo.control.material_id import EffusivityEstimate, load_effusivity_table
from telethermo.control.params import default_params
from telethermo.control.types import Role
from telethermo.inputfile import InputFileError
from telethermo.offline.material_touches import finger_natural_C, simulate_touch
from telethermo.sim.tem import load_rig_params

TABLE = load_effusivity_table()
REFERENCES = ("pvc", "glass", "stainless_steel")


def synthetic(n: int, offset: float, scale: float, noise_ln: float, seed: int) -> list[ml.LabTouch]:
    """``n`` touches of the three references whose fit reads ln b_fit = (ln b − offset)/scale + noise (so
    that offset + scale·ln b_fit = ln b + scale·noise)."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n):
        m = REFERENCES[i % 3]
        x = (math.log(TABLE[m]) - offset) / scale + rng.normal(0.0, noise_ln)
        out.append(ml.LabTouch(ln_b_fit=x, se_ln_b=0.02, b_true=TABLE[m], material=m))
    return out


def test_the_fit_recovers_a_known_offset_and_scale():
    """12 touches, ln b_fit = (ln b − 2)/0.7 + N(0, 0.1): the least-squares slope's standard error is
    0.7·0.1/(√12·sd(ln b_fit)) ≈ 0.016 and the fit lands within 4 of them over 20 draws; the floor is the
    shipped one it corrects (the residuals' σ 0.07 lies below it; their RMS within its 99.9 % chi-square
    bound 0.13); an offset alone, the wrong model, leaves residuals of 0.49, four times that."""
    y = np.log([TABLE[REFERENCES[i % 3]] for i in range(12)])
    se_scale = 0.7 * 0.1 / (math.sqrt(12) * float(np.std((y - 2.0) / 0.7)))
    for seed in range(20):
        w = ml.fit_window(synthetic(12, 2.0, 0.7, 0.1, seed), 0.3, mp.EARLY)
        assert w.model == "affine" and w.n_touches == 12
        assert abs(w.scale - 0.7) < 4 * se_scale
        assert abs(float(w.ln_b(math.log(TABLE["glass"]) / 0.7 - 2.0 / 0.7)) - math.log(TABLE["glass"])) < 0.1
        assert w.floor_ln == mp.EARLY.floor_ln and w.rms_after_ln < 0.13 < 0.5 < w.rms_before_ln
    touches = synthetic(12, 2.0, 0.7, 0.1, 0)
    offset_only = np.mean([math.log(t.b_true) - t.ln_b_fit for t in touches])
    resid = [math.log(t.b_true) - (offset_only + t.ln_b_fit) for t in touches]
    assert float(np.sqrt(np.mean(np.square(resid)))) > 0.4


def test_the_floor_is_refitted_from_the_residuals():
    """Noise 0.7 in ln b_fit at scale 1: the residual σ 0.7 (above the shipped floors 0.4 and 0.8) is found
    within 0.2 (24 touches: its standard error 0.1), the interval's floor wider than the likelihood's (a
    prediction interval); with σ 0.1 both floors stay the shipped ones."""
    w = ml.fit_window(synthetic(24, 0.5, 1.0, 0.7, 3), 1.2, mp.LATE)
    assert abs(w.floor_ln - 0.7) < 0.2 and w.floor_ci_ln > max(w.floor_ln, mp.LATE.floor_ci_ln)
    w = ml.fit_window(synthetic(24, 0.5, 1.0, 0.1, 3), 1.2, mp.LATE)
    assert (w.floor_ln, w.floor_ci_ln) == (mp.LATE.floor_ln, mp.LATE.floor_ci_ln)


def test_few_touches_or_one_material_fit_an_offset_only():
    w = ml.fit_window(synthetic(3, 1.0, 1.0, 0.05, 1), 0.3, mp.EARLY)
    assert (w.model, w.scale) == ("offset", 1.0) and "3 touches" in w.why and abs(w.offset_ln - 1.0) < 0.1
    one = [ml.LabTouch(7.0 + 0.01 * i, 0.02, TABLE["glass"], "glass") for i in range(8)]
    w = ml.fit_window(one, 0.3, mp.EARLY)
    assert w.model == "offset" and "span" in w.why
    # three touches that agree exactly cannot claim perfection: the floors stay the shipped ones
    exact = [ml.LabTouch(math.log(TABLE[m]) - 1.0, 0.0, TABLE[m], m) for m in REFERENCES]
    w = ml.fit_window(exact, 0.3, mp.EARLY)
    assert (w.floor_ln, w.floor_ci_ln) == (mp.EARLY.floor_ln, mp.EARLY.floor_ci_ln) and w.rms_after_ln < 1e-12
    tiny = replace(mp.EARLY, floor_ln=0.0, floor_ci_ln=0.0)
    assert ml.fit_window(exact, 0.3, tiny).floor_ci_ln == ml.MIN_FLOOR_LN
    with pytest.raises(ValueError, match="no reference touch"):
        ml.fit_window([], 0.3, mp.EARLY)


def _est(b: float) -> EffusivityEstimate:
    return EffusivityEstimate(b=b, se_ln_b=0.1, T_object0_C=20.0, R_contact_K_per_W=0.0, residual_C=0.0, n=30)


def test_the_identity_is_the_shipped_calibration_itself():
    est = _est(1234.5)
    assert mp.EARLY.corrected(est) is est and mp.LATE.corrected(None) is None
    p = default_params(Role.SLAVE, period_s=0.01).material_id
    assert ml.lab_params(p, None) is p
    lb = np.log([b for _, _, b in p.classes])
    w = ml.LabWindow(window_s=0.3, offset_ln=0.4, scale=0.8, floor_ln=0.3, floor_ci_ln=0.9)
    cal = w.calibration(mp.EARLY)
    c = cal.corrected(est)
    assert c.se_ln_b == pytest.approx(0.08) and math.log(c.b) == pytest.approx(0.4 + 0.8 * math.log(1234.5))
    moved = replace(est, b=c.b, se_ln_b=c.se_ln_b)
    floors = replace(mp.EARLY, floor_ln=0.3, floor_ci_ln=0.9)
    assert mp.decide(est, 33.6, lb, cal) == mp.decide(moved, 33.6, lb, floors)


def _touch(core, mat: str = "glass"):
    rig = load_rig_params()
    return simulate_touch(
        rig,
        mat,
        0.02,
        20.0,
        6.0,
        finger_natural_C(rig),
        seed=4141,
        t_on_s=0.205,
        post_s=1.45,
        core_params=core,
    )[3]


def test_a_lab_correction_reaches_the_published_answer_and_the_identity_moves_nothing():
    """Through the slave's core (physics posterior only: no networks): the lab file of the identity, with
    the shipped floors, publishes the same answer to the last digit; a correction publishes exp(a + c·ln b)
    of the same fit with its own interval."""
    cp = default_params(Role.SLAVE, period_s=0.01)
    mid = replace(cp.material_id, calibration=None, envelope=None, envelope_late=None)
    base = _touch(replace(cp, material_id=mid))
    assert base.stage == "late" and math.isfinite(base.effusivity)
    ident = ml.LabCorrection(
        early=ml.LabWindow(0.3, floor_ln=mp.EARLY.floor_ln, floor_ci_ln=mp.EARLY.floor_ci_ln, n_touches=3),
        late=ml.LabWindow(1.2, floor_ln=mp.LATE.floor_ln, floor_ci_ln=mp.LATE.floor_ci_ln, n_touches=3),
    )
    assert _touch(replace(cp, material_id=ml.lab_params(mid, ident))) == base
    lab = ml.LabCorrection(
        early=ml.LabWindow(0.3, offset_ln=0.7, scale=0.9, floor_ln=0.2, floor_ci_ln=0.5, n_touches=6),
        late=ml.LabWindow(1.2, offset_ln=-0.5, scale=1.1, floor_ln=0.25, floor_ci_ln=0.6, n_touches=6),
    )
    got = _touch(replace(cp, material_id=ml.lab_params(mid, lab)))
    assert math.log(got.effusivity) == pytest.approx(-0.5 + 1.1 * math.log(base.effusivity), abs=1e-9)
    # the published σ of ln b: hypot(k_ci·scale·se, floor_ci) with se recovered from the identity's
    se = math.sqrt(max(base.se_ln_b**2 - mp.LATE.floor_ci_ln**2, 0.0)) / mp.LATE.k_ci
    assert got.se_ln_b == pytest.approx(math.hypot(mp.LATE.k_ci * 1.1 * se, 0.6), rel=1e-6)
    assert got.T_object0_C == base.T_object0_C


def test_the_lab_file_round_trips_and_refuses_bad_fields(tmp_path):
    lab = ml.LabCorrection(
        early=ml.fit_window(synthetic(12, 2.0, 0.7, 0.1, 0), 0.3, mp.EARLY),
        late=ml.fit_window(synthetic(3, 0.2, 1.0, 0.1, 1), 1.2, mp.LATE),
    )
    path = ml.save_lab(tmp_path / "lab.json", lab, {"touches": 12})
    assert ml.load_lab(path) == lab
    doc = json.loads(path.read_text())
    for field, value, expected in (
        ("early.scale", 9.0, "early.scale: expected a number in [0.2, 5]"),
        ("late.floor_ci_ln", 0.01, "late.floor_ci_ln: expected a number in [0.15, 10]"),
        ("early.model", "cubic", "early.model: expected one of affine, offset"),
        ("late.scale", 0.9, "late.scale: expected 1 with model offset"),
    ):
        bad = json.loads(json.dumps(doc))
        section, key = field.split(".")
        bad[section][key] = value
        (tmp_path / "bad.json").write_text(json.dumps(bad))
        with pytest.raises(InputFileError, match=re.escape(expected)) as exc:
            ml.load_lab(tmp_path / "bad.json")
        assert str(tmp_path / "bad.json") in str(exc.value) and "\n" not in str(exc.value)
    p = default_params(Role.SLAVE, period_s=0.01).material_id
    wrong = ml.LabCorrection(early=replace(lab.early, window_s=0.5))
    with pytest.raises(ValueError, match="early.window_s"):
        ml.lab_params(p, wrong)
