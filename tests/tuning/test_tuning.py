"""Gain tuning (telethermo.tuning): deterministic objective, bounded search, robust choice, gains file.

The search tests use a cheap analytic objective (same class, sessions replaced); the session tests
run short scenes. No wall-clock assertions.
"""

import json
import math

import numpy as np
import pytest

from telethermo import tuning as tn
from telethermo.control.defaults import GAINS
from telethermo.control.params import default_params
from telethermo.control.types import Role

sim = pytest.importorskip("sim")

SCENE = "probe_touches_al_steel_wood"
#: the gains shipped before the tuner (random search of ~400 sets, docs/control.md): the reference point
REFERENCE = {
    "master.kp_A_per_C": 1.0,
    "master.ki_A_per_C_s": 0.1,
    "master.kpQ_A_per_W": 0.4,
    "slave.kp_A_per_C": 0.5,
    "slave.ki_A_per_C_s": 0.1,
    "slave.kpQ_A_per_W": 0.05,
}


class Analytic(tn.Objective):
    """The Objective machinery (memo, history, bounds, budget) with a quadratic bowl in log-gains whose
    minimum lies partly *outside* the box (so a careless optimiser would step out)."""

    def __init__(self, space=tn.DEFAULT_SPACE):
        super().__init__([object()], space=space)
        self.centre = {s.key: (s.hi * 3.0 if i % 2 else s.lo / 3.0) for i, s in enumerate(self.space)}
        self.seen = []

    def evaluate(self, gains):
        gains = {k: float(v) for k, v in gains.items()}
        self.seen.append(dict(gains))
        key = self.memo_key(gains)
        if key in self._cache:
            return self._cache[key]
        J = sum((math.log(gains[k]) - math.log(c)) ** 2 for k, c in self.centre.items())
        ev = tn.Evaluation(gains=gains, J=J, scenes=[])
        self._cache[key] = ev
        self.history.append(ev)
        return ev


def _inside(g, space):
    return all(s.lo <= g[s.key] <= s.hi for s in space)


@pytest.mark.parametrize("method", ["nelder-mead", "de"])
def test_search_never_leaves_its_bounds_and_keeps_its_budget(method):
    obj = Analytic()
    res = tn.search(obj, budget=40, method=method, seed=3)
    assert res.proposals and obj.seen
    for g in res.proposals + [p.gains for p in res.points]:
        assert _inside(g, obj.space), g
    # everything else evaluated is a stress corner of a proposed point (a check around it, not a proposal)
    corners = {obj.memo_key(c) for p in res.points for c in tn.stress_corners(p.gains, obj.space, 0.3)}
    for g in obj.seen:
        assert _inside(g, obj.space) or obj.memo_key(g) in corners
    assert len(res.points) <= 40 and res.n_evaluations <= 3 * 40  # a point = the centre + 2 stress corners
    assert res.best.value <= res.start.value
    # the minimum is in a corner of the box: the search heads there
    assert res.best.centre.J < res.start.centre.J
    # the searched value is the worst of the centre and its stress corners
    for p in res.points:
        assert p.value == max([p.centre.J] + [e.J for e in p.stress]) and len(p.stress) == 2


def test_stress_corners_follow_the_stiffness_direction():
    g = tn.default_gains()
    stiff, soft = tn.stress_corners(g, tn.DEFAULT_SPACE, 0.3)
    for s in tn.DEFAULT_SPACE:
        up = stiff[s.key] > g[s.key]
        assert up == (s.stiff > 0) and (soft[s.key] > g[s.key]) == (not up)
        assert stiff[s.key] / g[s.key] == pytest.approx(1.3 if up else 0.7)
    res = tn.search(Analytic(), budget=5, stress_rel=0.0)
    assert all(p.stress == [] and p.value == p.centre.J for p in res.points)


def test_search_is_deterministic_for_a_seed():
    a = tn.search(Analytic(), budget=30, method="de", seed=5)
    b = tn.search(Analytic(), budget=30, method="de", seed=5)
    assert a.best.gains == b.best.gains and a.proposals == b.proposals
    assert [p.value for p in a.points] == [p.value for p in b.points]


def test_tune_chooses_the_best_worst_case_and_the_box_is_around_it():
    obj = Analytic()
    res = tn.tune(obj, budget=30, method="nelder-mead", candidates=2, rel=0.3, corners=2)
    pool = res.candidates + [res.reference]
    eligible = [r for r in pool if r.centre.J <= res.reference.centre.J]
    assert res.chosen in eligible  # never worse than the reference (the shipped gains) at the centre
    assert res.chosen.worst.J == min(r.worst.J for r in eligible)
    assert res.chosen.centre.J < res.reference.centre.J  # the bowl's minimum is away from the shipped gains
    labels = [lab for lab, _ in res.chosen.rows]
    assert len(labels) == 2 * len(obj.space) + 2
    c = res.chosen.centre.gains
    for lab, ev in res.chosen.rows[: 2 * len(obj.space)]:
        changed = [k for k in c if not math.isclose(ev.gains[k], c[k])]
        assert len(changed) == 1 and changed[0] in lab
        r = ev.gains[changed[0]] / c[changed[0]]
        assert r == pytest.approx(0.7) or r == pytest.approx(1.3)


def test_log_gain_mapping_clips_to_the_bounds():
    obj = Analytic()
    lo = obj.to_gains(np.full(len(obj.space), -50.0))
    hi = obj.to_gains(np.full(len(obj.space), 50.0))
    assert lo == {s.key: s.lo for s in obj.space} and hi == {s.key: s.hi for s in obj.space}
    g = tn.default_gains(obj.space)
    assert obj.to_gains(obj.to_x(g)) == pytest.approx(g, rel=1e-3)


def test_gain_specs_are_validated():
    with pytest.raises(ValueError):
        tn.GainSpec("master", "kp_A_per_C", 0.0, 1.0)  # log space needs lo > 0
    with pytest.raises(ValueError):
        tn.GainSpec("display", "kp_A_per_C", 0.1, 1.0)
    with pytest.raises(ValueError):
        tn.GainSpec("master", "gain", 0.1, 1.0)
    with pytest.raises(ValueError):
        tn.GainSpec("master", "kp_A_per_C", 0.1, 1.0, stiff=0)


def test_objective_is_deterministic_for_a_seed():
    scenes = tn.tuning_scenes(SCENE)
    a = tn.Objective(scenes, seed=0, duration_s=5.0).evaluate(REFERENCE)
    b = tn.Objective(tn.tuning_scenes(SCENE), seed=0, duration_s=5.0).evaluate(dict(REFERENCE))
    assert a.J == b.J and a.scenes == b.scenes
    assert math.isfinite(a.J) and len(a.scenes) == 2


def test_perturbed_scene_differs_in_room_finger_force_and_objects():
    sc = sim.load_scene(SCENE)
    p = tn.perturbed_scene(sc)
    assert p.ambient_C != sc.ambient_C and p.finger != sc.finger and p.seed != sc.seed
    assert {o.material for o in p.objects.values()}.isdisjoint({o.material for o in sc.objects.values()})
    assert all(t.force_N < 6.0 for t in p.slave_contacts)  # below full contact: a contact resistance
    assert [t.start_s for t in p.slave_contacts] == [t.start_s for t in sc.slave_contacts]
    with pytest.raises(ValueError):
        tn.tuning_scenes("virtual_materials")


def test_score_penalises_safety_and_instability():
    figs = {
        "transparency": {"early_mean_error_C": 0.5, "late_mean_error_C": 0.2, "per_contact": []},
        "tracking": {"rms_C": 0.1},
        "discrimination": {"order_kept": True, "margins_C": [0.2, 0.8], "reference_margins_C": [0.1, 1.8]},
        "safety": {
            "time_at_limit_s": {"master": {"ramp": 1.0}, "slave": {}},
            "time_cut_s": {"master": 0.0},
            "n_trips": 0,
        },
    }
    J, _ = tn.score_figures(figs)
    assert J == pytest.approx(2.0 + 0.2 + 0.05)  # margins reach min(reference, 0.7 °C): no shortfall
    figs["discrimination"]["margins_C"] = [0.05, 0.5]
    assert tn.score_figures(figs)[0] == pytest.approx(J + 2.0 * (0.05 + 0.2))
    figs["discrimination"]["margins_C"] = [0.2, 0.8]
    figs["safety"]["n_trips"] = 1
    assert tn.score_figures(figs)[0] > J + 1
    figs["tracking"]["rms_C"] = None
    assert tn.score_figures(figs)[0] == tn.UNSTABLE_J


#: the most robust point of `telethermo tune --budget 40 --stress 0.15` (bench/results/tuning.json):
#: better on the two-scene objective and over the ±30 % box, worse on the guiatni scene alone
ROBUST = {
    "master.kp_A_per_C": 0.7319,
    "master.ki_A_per_C_s": 0.1631,
    "master.kpQ_A_per_W": 0.2752,
    "slave.kp_A_per_C": 0.492,
    "slave.ki_A_per_C_s": 0.1097,
    "slave.kpQ_A_per_W": 0.06887,
}


def test_tuned_defaults_are_at_least_as_good_as_the_reference_on_the_objective():
    obj = tn.Objective(tn.tuning_scenes(SCENE), seed=0)
    tuned = obj.evaluate(tn.default_gains(obj.space))
    ref = obj.evaluate(REFERENCE)
    assert tuned.J <= ref.J + 1e-9
    # why the defaults were kept (docs/tuning.md): on the guiatni scene itself the shipped gains beat the
    # tuner's most robust point, whose gain comes from the perturbed scene and the tracking figure
    nominal = tn.Objective(tn.tuning_scenes(SCENE, perturbed=False), seed=0)
    assert nominal.evaluate(tn.default_gains(obj.space)).J < nominal.evaluate(ROBUST).J


def test_gains_file_round_trip(tmp_path):
    obj = Analytic()
    res = tn.tune(obj, budget=8, candidates=1, corners=0)
    obj.scenes = [sim.load_scene(SCENE)]
    doc = tn.gains_document(res, obj)
    # the file marks what a running node takes by SDO and what needs a start with --gains (apply-gains)
    assert doc["apply"] == {
        "mode": "telepresence",
        "sdo": ["kp_A_per_C", "ki_A_per_C_s", "kQ_A_per_W"],
        "restart": ["kpQ_A_per_W", "kiQ_A_per_W_s"],
    }
    path = tn.write_gains(tmp_path / "gains.json", doc)
    loaded = tn.load_gains(path)
    for role in (Role.MASTER, Role.SLAVE):
        assert set(loaded[role]) == set(tn.GAIN_FIELDS)
        p = default_params(role, **loaded[role])
        assert p.kp_A_per_C == res.best.gains[f"{role.value}.kp_A_per_C"]
    bad = json.loads(path.read_text())
    bad["master"]["kp_A_per_C"] = -1.0
    (tmp_path / "bad.json").write_text(json.dumps(bad))
    with pytest.raises(ValueError, match="kp_A_per_C"):
        tn.load_gains(tmp_path / "bad.json")
    bad["master"] = {"kx": 1.0}
    (tmp_path / "bad.json").write_text(json.dumps(bad))
    with pytest.raises(ValueError, match="kx"):
        tn.load_gains(tmp_path / "bad.json")
    with pytest.raises(ValueError, match="no such"):
        tn.load_gains(tmp_path / "missing.json")


def test_the_shipped_gains_are_inside_the_default_space():
    assert _inside(tn.default_gains(), tn.DEFAULT_SPACE)
    assert _inside(REFERENCE, tn.DEFAULT_SPACE)
    for role in (Role.MASTER, Role.SLAVE):
        # every tuned gain has a shipped value (the defaults also carry non-gain settings: air rendering, the
        # air flux loop, the slave's contact source)
        assert set(tn.GAIN_FIELDS) <= set(GAINS[role])


def test_cli_tune_writes_a_loadable_gains_file(tmp_path, capsys):
    import argparse

    from telethermo.cli import tune as cli

    ap = argparse.ArgumentParser()
    sub = ap.add_subparsers()
    cli.register(sub)
    out = tmp_path / "gains.json"
    args = ap.parse_args(
        [
            "tune",
            "--scene",
            SCENE,
            "--duration",
            "4",
            "--budget",
            "2",
            "--candidates",
            "1",
            "--corners",
            "0",
            "--no-perturbed",
            "--quiet",
            "--out",
            str(out),
        ]
    )
    assert args.func(args) == 0
    text = capsys.readouterr().out
    assert "sensitivity of the chosen point" in text and "master.kp_A_per_C +30%" in text
    g = tn.load_gains(out)
    doc = json.loads(out.read_text())
    assert doc["search"]["budget_points"] == 2 and doc["objective"]["scenes"] == [SCENE]
    assert _inside({f"{r.value}.{k}": v for r, d in g.items() for k, v in d.items()}, tn.DEFAULT_SPACE)


@pytest.mark.parametrize(
    "argv",
    [
        ["--budget", "0"],
        ["--rel", "1.5"],
        ["--scene", "virtual_materials"],
        ["--scene", "no_such_scene"],
        ["--start", "missing.json"],
        ["--duration", "2"],  # ends before the first touch (t_on 1 s) is scored: every J would be 100
    ],
)
def test_cli_tune_refuses_bad_arguments(argv):
    import argparse

    from telethermo.cli import tune as cli
    from telethermo.cli.main import UserError

    ap = argparse.ArgumentParser()
    sub = ap.add_subparsers()
    cli.register(sub)
    base = ["tune", "--scene", SCENE] if "--scene" not in argv else ["tune"]
    args = ap.parse_args(base + argv)
    with pytest.raises(UserError):
        args.func(args)


@pytest.mark.parametrize(
    ("option", "field"),
    [
        ("--w-early", "early_per_C"),
        ("--w-late", "late_per_C"),
        ("--w-tracking", "tracking_per_C"),
        ("--w-margin", "margin_per_C"),
        ("--w-limit", "limit_per_s"),
    ],
)
def test_cli_tune_each_weight_option_sets_its_own_weight(option, field):
    import argparse
    import dataclasses

    from telethermo.cli import tune as cli
    from telethermo.cli.main import UserError

    ap = argparse.ArgumentParser()
    cli.register(ap.add_subparsers())
    weights = cli._weights(ap.parse_args(["tune", "--scene", SCENE, option, "7.5"]))
    assert weights == dataclasses.replace(tn.Weights(), **{field: 7.5})
    with pytest.raises(UserError, match=rf"^{option} -1.0: expected a finite number >= 0$"):
        cli._weights(ap.parse_args(["tune", "--scene", SCENE, option, "-1"]))


def test_cli_tune_record_holds_every_evaluation(tmp_path, capsys):
    import argparse

    from telethermo.cli import tune as cli

    ap = argparse.ArgumentParser()
    cli.register(ap.add_subparsers())
    rec = tmp_path / "run.json"
    args = ap.parse_args(
        [
            "tune",
            "--scene",
            SCENE,
            "--duration",
            "4",
            "--budget",
            "1",
            "--candidates",
            "1",
            "--corners",
            "0",
            "--stress",
            "0",
            "--no-perturbed",
            "--quiet",
            "--record",
            str(rec),
        ]
    )
    assert args.func(args) == 0
    assert f"wrote {rec}" in capsys.readouterr().out
    doc = json.loads(rec.read_text())
    assert doc["scenes"] == [SCENE] and doc["budget"] == 1
    assert len(doc["history"]) == doc["evaluations"] >= 1
    assert doc["gains_file"]["format"] == tn.GAINS_FORMAT
    assert doc["chosen"]["J"] == doc["gains_file"]["objective"]["J"]
