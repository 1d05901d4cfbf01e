"""Property tests on random scenes: no NaN, physically bounded temperatures, determinism with a seed."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings, strategies as st, HealthCheck

from telethermo import sim
from tests.sim.conftest import make_scene

MATERIALS = [
    "eps",
    "oak",
    "pvc",
    "glass",
    "ceramic",
    "stainless_steel",
    "carbon_steel",
    "brass",
    "aluminium",
    "copper",
]


@st.composite
def scenes(draw):
    n_obj = draw(st.integers(1, 3))
    objects = {}
    for k in range(n_obj):
        objects[f"o{k}"] = {
            "material": draw(st.sampled_from(MATERIALS)),
            "thickness_mm": draw(st.floats(0.05, 40.0)),
            "T0_C": draw(st.floats(5.0, 45.0)),
            "back": draw(st.sampled_from(["adiabatic", "ambient"])),
        }
    t, slave = 0.0, []
    for _ in range(draw(st.integers(0, 4))):
        t += draw(st.floats(0.0, 0.4))
        d = draw(st.floats(0.013, 0.5))
        slave.append(
            (round(t, 3), round(t + d, 3), draw(st.sampled_from(sorted(objects))), draw(st.floats(0.1, 12.0)))
        )
        t = round(t + d, 3) + 0.001
    duration = max(t, 0.5) + 0.2
    mode = draw(st.sampled_from(["always", "none", "intermittent"]))
    if mode == "always":
        master = [(0.0, duration, "finger", draw(st.floats(0.5, 10.0)))]
    elif mode == "none":
        master = []
    else:  # the finger lifts and touches again (attach/detach of the finger)
        master, tm = [], 0.0
        while True:
            tm += draw(st.floats(0.0, 0.3))
            d = draw(st.floats(0.013, 0.4))
            if tm + d > duration:
                break
            master.append((round(tm, 3), round(tm + d, 3), "finger", draw(st.floats(0.1, 12.0))))
            tm = round(tm + d, 3) + 0.001
    ambient = draw(st.floats(15.0, 35.0))
    period = draw(st.sampled_from([0.001, 0.005, 0.01, 0.02]))
    return make_scene(
        master=master,
        slave=slave,
        objects=objects,
        kind="telepresence",
        duration=duration,
        period=period,
        ambient=ambient,
        noise={"seed": 1},
    )


def run(scene, role, currents, seed=5):
    rig = sim.build_rig(scene, role, seed=seed)
    out = []
    for k in range(int(scene.duration_s / scene.period_s)):
        rig.apply_current(currents[k % len(currents)])
        rig.advance(scene.period_s)
        s, tr = rig.read(), rig.truth()
        out.append((s.T_sensor_C, s.Q_W, s.contact, tr.T_pad_C, tr.T_surface_C, tr.T_sink_C))
    return rig, out


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scene=scenes(), role=st.sampled_from(["master", "slave"]))
def test_no_current_obeys_the_maximum_principle(scene, role):
    """Without current there is no source: every temperature stays within the initial/reservoir range."""
    objs = [o.T0_C for o in scene.objects.values()]
    lo = min([scene.ambient_C, *objs]) - 1e-6
    hi = max([scene.ambient_C, 37.0, *objs]) + 1e-6
    rig, out = run(scene, role, [0.0])
    for T_sensor, Q, contact, T_pad, T_surf, T_sink in out:
        for T in (T_pad, T_sink):
            assert lo <= T <= hi
        assert math.isnan(T_surf) or lo <= T_surf <= hi
        assert math.isfinite(T_sensor) and math.isfinite(Q)
        assert lo - 0.2 <= T_sensor <= hi + 0.2  # noise 0.02 °C, filtered
    assert np.all(np.isfinite(rig.x))


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    scene=scenes(),
    role=st.sampled_from(["master", "slave"]),
    currents=st.lists(st.floats(-3.0, 3.0), min_size=1, max_size=8),
)
def test_random_currents_stay_finite_bounded_and_deterministic(scene, role, currents):
    rig, out = run(scene, role, currents)
    for row in out:
        for v in (row[0], row[1], row[3], row[5]):
            assert math.isfinite(v) and -60.0 < v < 150.0
    _, again = run(scene, role, currents)
    assert np.array_equal(np.array(out, dtype=float), np.array(again, dtype=float), equal_nan=True)
    bal = rig.energy_balance()
    scale = max(abs(bal["E_in_J"]), abs(bal["E_out_J"]), abs(bal["dE_stored_J"]))
    # + 1e-7 J: the float rounding of the balance itself. The stored heat is ~1e3 J (a 40 J/K sink at 34 °C),
    # so each step's difference rounds at ~1e-13 J; hypothesis found a run with 1e-6 J of flows (0 A, the room
    # at the finger's temperature) and a 1.1e-9 J residual. A real leak of 0.1 % in a run with flows above
    # 1e-4 J still exceeds the floor.
    assert abs(bal["residual_J"]) <= 1e-3 * scale + 1e-7
