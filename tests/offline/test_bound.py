"""The optimal-current bound (telethermo/offline/bound.py; bench/transparency_bench.py runs it): its batched
plant is the simulator (a replay through sim.SimRig agrees to 1e-9 °C), the matched start is the direct-touch
finger, and optimising helps; the clamped bound keeps the skin inside its clamps and pays for it."""

import copy

import numpy as np
import pytest

from telethermo import sim
from telethermo.offline.bound import (
    BatchedPlant,
    Window,
    _optimise,
    causal_bound,
    clamp_excess,
    cooling_peak_A,
    matched_start,
    replay,
    window_errors,
)

PERIOD = 0.01


@pytest.fixture(scope="module")
def setup():
    sc = sim.load_scene("probe_touches_al_steel_wood")
    ref = sim.build_reference(sc)
    t_on = sc.slave_contacts[0].start_s
    k0 = int(round(t_on / PERIOD)) - 50
    skin = []
    cells = None
    for k in range(k0 + 150):
        if k == k0:
            ref.finger.advance_detached(ref.t_s)
            cells = ref.finger.x[: ref.finger.n].copy()
        skin.append(ref.T_contact_C)
        ref.advance(PERIOD)
    mk = lambda: sim.build_rig(sc, "master", noise=False)  # noqa: E731
    rig = mk()
    w = Window(
        t0_s=k0 * PERIOD, n_pre=50, n_early=100, x0=matched_start(rig, cells), ref_C=np.array(skin[k0:])
    )
    return sc, mk, BatchedPlant(rig, PERIOD), w


def test_batched_plant_is_the_simulator(setup):
    _, mk, plant, w = setup
    rng = np.random.default_rng(0)
    u = np.clip(rng.normal(0.0, 1.2, 150), -plant.I_lim, plant.I_lim)
    batched = plant.run(w.x0, u[:-1, None])[:, 0]
    replayed = replay(mk, w, u, PERIOD)
    assert np.max(np.abs(batched - replayed)) <= 1e-9
    # several columns at once give each column's own trajectory
    U = np.stack([u[:-1], -u[:-1], np.zeros(149)], axis=1)
    S = plant.run(w.x0, U)
    for j in range(3):
        assert np.max(np.abs(S[:, j] - replay(mk, w, np.append(U[:, j], 0.0), PERIOD))) <= 1e-9


def test_matched_start_is_the_direct_touch_finger(setup):
    _, _, plant, w = setup
    # the finger's cells are the reference finger's; its skin (a face value) differs only by what the pad at
    # the in-air surface temperature does across the contact resistance instead of air: under 1 mK
    assert plant.skin(w.x0[:, None])[0] == pytest.approx(w.ref_C[0], abs=1e-3)


def test_causal_bound_beats_doing_nothing_and_replays(setup):
    _, mk, plant, w = setup
    u = causal_bound(plant, w, maxiter=30)
    assert np.all(np.abs(u) <= plant.I_lim + 1e-12)
    skin = plant.run(w.x0, u[:-1, None])[:, 0]
    assert np.max(np.abs(skin - replay(mk, w, u, PERIOD))) <= 1e-9
    e = window_errors(skin, w)
    zero = window_errors(plant.run(w.x0, np.zeros((149, 1)))[:, 0], w)
    assert e["pre_C"] <= 0.05  # before the touch it keeps the finger matched
    assert e["early_C"] < zero["early_C"] - 0.5  # on aluminium it cools far better than no current


def test_clamped_bound_keeps_the_skin_inside_and_costs_what_the_clamp_costs(setup):
    _, _, plant, w = setup
    free = plant.run(w.x0, causal_bound(plant, w, maxiter=30)[:-1, None])[:, 0]
    lo = float(np.min(free)) + 1.5  # the free bound cools the skin 1.5 °C past this
    clamp = (lo, 43.0)
    u = causal_bound(plant, w, maxiter=30, clamp_C=clamp)
    assert np.all(np.abs(u) <= plant.I_lim + 1e-12)
    skin = plant.run(w.x0, u[:-1, None])[:, 0]
    assert np.max(clamp_excess(free, clamp)) > 1.4
    assert np.max(clamp_excess(skin, clamp)) <= 0.05  # the penalty holds it (0.1 °C costs 1 °C·sample)
    e, e_free = window_errors(skin, w), window_errors(free, w)
    # a skin inside the clamps is at least as far from the direct touch as the clipped direct touch is
    ideal = window_errors(np.clip(w.ref_C, *clamp), w)
    assert e["early_C"] >= ideal["early_C"] - 0.02
    assert e["early_C"] > e_free["early_C"] + 0.1  # the clamp binds, so the bound costs more
    # and it still drives the skin down to the clamp at full current, far better than no current
    zero = window_errors(plant.run(w.x0, np.zeros((149, 1)))[:, 0], w)
    assert e["early_C"] < zero["early_C"] - 0.3


def test_a_search_started_past_the_cooling_peak_needs_the_restart(setup):
    _, _, plant, w = setup
    weak = copy.copy(plant)
    weak.R = 4.0 * plant.R  # a high-resistance module: more cooling current warms past αT/R
    peak = cooling_peak_A(float(np.max(weak.alpha)), float(np.max(weak.R)), 40.0)
    assert peak < 0.5 * weak.I_lim  # the peak lies well inside the limit, at any plate temperature ≤ 40 °C
    n = 99
    ref = np.append(w.ref_C[0] + 2.0 * np.ones(n + 1), 0.0)  # the skin should warm by 2 °C
    wt = np.ones(n + 2)
    wt[0] = 0.0

    def err(u):
        return float(np.abs(weak.run(w.x0, u[:, None])[1:, 0] - ref[1 : n + 1]).mean())

    stuck = _optimise(weak, w.x0, np.zeros(0), n, ref, wt, -weak.I_lim, 30)
    both = _optimise(weak, w.x0, np.zeros(0), n, ref, wt, -weak.I_lim, 30, restarts_A=(0.0,))
    # from the cooling limit, the search warms by Joule heat only and stops there
    assert np.all(stuck < -peak)
    # the restart from 0 A heats with the Peltier term, the way that reaches the target
    assert np.median(both) > 0.0
    assert err(both) < err(stuck) - 0.3
