"""sim.wallclock.WallClockRig: a simulated rig paced by an (injected) clock, with no ``advance``.

The clock is injected and stepped by hand; the plant is the real simulator. The wrapped rig must equal the
inner rig advanced by hand by the same time steps with the same currents, bit for bit."""

from __future__ import annotations

import ast
import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from telethermo import sim
from telethermo.sim.wallclock import (
    DEFAULT_MAX_CATCH_UP_S,
    WallClockRig,
    pads_in_air_master,
    pads_in_air_slave,
    probe_master,
    probe_slave,
    wall_clock_rig,
)
from telethermo.rig import Rig, RigSample, SimulatedRig

PROBE = "probe_touches_al_steel_wood"


class HandClock:
    """A monotonic clock stepped by hand, s."""

    def __init__(self, t0: float = 1000.0) -> None:
        self.t = t0

    def __call__(self) -> float:
        return self.t

    def step(self, dt: float) -> float:
        """Move on by ``dt``; return the gap a reader of the clock sees (``new - old`` in floating point)."""
        old = self.t
        self.t += dt
        return self.t - old


def _fields(s: RigSample) -> tuple:
    return dataclasses.astuple(s)


def test_is_a_rig_without_advance():
    rig = pads_in_air_master()
    assert isinstance(rig, Rig)
    assert not isinstance(rig, SimulatedRig)
    assert not hasattr(rig, "advance")
    assert not callable(getattr(rig, "advance", None))  # what nodes.parts tests to choose the real-time path
    assert rig.period_s == 0.01 and rig.I_max_A == rig.inner.I_max_A > 0


def test_wrapped_equals_inner_advanced_by_the_same_steps_bit_for_bit():
    """Irregular read times (jitter, a short stall, a contact make/break inside a step): every sample and the
    truth equal an identical rig advanced by hand by the same gaps, with the same currents."""
    scene = sim.load_scene(PROBE)
    clock = HandClock()
    rig = WallClockRig(sim.build_rig(scene, "slave", seed=1), clock=clock)
    ref = sim.build_rig(scene, "slave", seed=1)
    rng = np.random.default_rng(7)
    gaps = 0.01 + rng.uniform(-0.004, 0.004, 400)
    gaps[100] = 0.25  # a stall (below the catch-up cap)
    s0 = rig.read()  # the plant's clock starts here: t = 0
    assert _fields(s0) == _fields(ref.read()) and s0.t_s == 0.0
    t_ref = 0.0
    touched = False
    for k, gap in enumerate(gaps):
        I = 0.8 * math.sin(0.05 * k)
        rig.apply_current(I)
        ref.apply_current(I)
        gap = clock.step(gap)
        got = rig.read()
        ref.advance(gap)
        t_ref += gap
        want = ref.read()
        assert _fields(got) == _fields(want), k
        assert rig.truth() == ref.truth()
        touched |= got.contact
    assert touched  # the aluminium touch (1.0 s of scene time) happened
    assert rig.stats.simulated_s == pytest.approx(t_ref, abs=1e-12)
    assert rig.inner.t_s == pytest.approx(t_ref, abs=1e-12)
    assert rig.stats.reads == 401 and rig.stats.advances == 400 and rig.stats.capped_catch_ups == 0
    assert rig.stats.max_gap_s == pytest.approx(0.25)


def test_contact_schedule_runs_in_the_plants_own_time():
    """The scene's touch at 1.0 s starts 1.0 s of clock after the first read, however long before that the rig
    was built and whatever the clock read then."""
    clock = HandClock(t0=5e5)
    rig = WallClockRig(sim.build_rig(sim.load_scene(PROBE), "slave", seed=1), clock=clock)
    clock.step(123.0)  # built long before the first read: nothing simulated
    assert not rig.started and rig.read().t_s == 0.0 and rig.started
    first_touch = None
    for _ in range(150):
        clock.step(0.01)
        s = rig.read()
        if s.contact and first_touch is None:
            first_touch = s.t_s
    assert first_touch == pytest.approx(1.0, abs=0.011)
    assert rig.stats.capped_catch_ups == 0


def test_current_is_held_between_reads():
    """A current commanded once is held over every later read's gap, until the next command: equal to an inner
    rig advanced with that current applied once; a later command changes only the time after the next read."""
    clock = HandClock()
    scene = sim.load_scene("pads_in_air")
    rig = WallClockRig(sim.build_rig(scene, "master", seed=0), clock=clock)
    ref = sim.build_rig(scene, "master", seed=0)
    rig.read()
    rig.apply_current(0.6)
    ref.apply_current(0.6)
    for gap in (0.01, 0.013, 0.007, 0.5):
        gap = clock.step(gap)
        s = rig.read()
        ref.advance(gap)
        assert s.current_A == 0.6 and _fields(s) == _fields(ref.read())
    assert rig.truth().T_pad_C > 26.0  # 0.53 s at 0.6 A: the pad warmed (truth; the filter lags)
    # two commands between the same two reads: the last one is what the plant holds
    rig.apply_current(-0.4)
    rig.apply_current(0.2)
    ref.apply_current(0.2)
    ref.advance(clock.step(0.01))
    assert _fields(rig.read()) == _fields(ref.read())
    # the drive's clip and NaN handling are the inner rig's
    rig.apply_current(1e6)
    assert rig.inner.I == rig.I_max_A
    rig.apply_current(float("nan"))
    assert rig.inner.I == 0.0


def test_a_read_with_no_time_elapsed_does_not_advance():
    clock = HandClock()
    rig = WallClockRig(sim.build_rig(sim.load_scene("pads_in_air"), "slave", seed=1), clock=clock)
    a = rig.read()
    clock.step(0.01)
    b = rig.read()
    c = rig.read()  # same clock reading: the same sample, nothing integrated
    assert b is c and b.t_s == pytest.approx(0.01) and a.t_s == 0.0
    assert rig.stats.reads == 3 and rig.stats.advances == 1


def test_a_huge_gap_is_capped_and_counted():
    """A stalled process (here 30 s between two reads) is simulated for max_catch_up_s only; the rest is
    skipped
    once (the plant's clock falls behind), counted, and the reads go on in real time from there."""
    clock = HandClock(t0=1024.0)  # binary-exact times: the gaps below are exact
    scene = sim.load_scene("pads_in_air")
    rig = WallClockRig(sim.build_rig(scene, "master", seed=0), clock=clock, max_catch_up_s=0.5)
    ref = sim.build_rig(scene, "master", seed=0)
    rig.read()
    rig.apply_current(0.3)
    ref.apply_current(0.3)
    assert clock.step(30.0) == 30.0
    s = rig.read()
    ref.advance(0.5)  # what the cap lets through
    assert _fields(s) == _fields(ref.read()) and s.t_s == 0.5
    assert rig.stats.capped_catch_ups == 1 and rig.stats.skipped_s == 29.5
    assert rig.stats.max_gap_s == 30.0
    assert clock.step(0.5) == 0.5  # a gap of exactly the cap: not capped
    ref.advance(0.5)
    assert _fields(rig.read()) == _fields(ref.read())
    for _ in range(3):
        ref.advance(clock.step(0.01))
        assert _fields(rig.read()) == _fields(ref.read())
    assert rig.stats.capped_catch_ups == 1  # ordinary gaps are not counted
    assert rig.stats.simulated_s == pytest.approx(0.5 + 0.5 + 0.03, abs=1e-12)
    assert rig.inner.t_s == pytest.approx(rig.stats.simulated_s, abs=1e-12)
    assert DEFAULT_MAX_CATCH_UP_S == WallClockRig(sim.build_rig(scene, "master")).max_catch_up_s == 1.0


def test_bad_arguments():
    scene = sim.load_scene("pads_in_air")
    with pytest.raises(TypeError, match="simulated rig"):
        WallClockRig(object())
    for bad in (0.0, -1.0, math.inf, math.nan):
        with pytest.raises(ValueError, match="max_catch_up_s"):
            WallClockRig(sim.build_rig(scene, "master"), max_catch_up_s=bad)
    with pytest.raises(ValueError, match="role"):
        wall_clock_rig("pads_in_air", "operator")


def test_factories_build_the_scenes_rigs_with_the_node_seeds():
    """The --rig factories: zero arguments, the scene's rig of that role, seeds as the node programs (master
    0,
    slave 1), so that the first sample equals sim.build_rig(scene, role, seed)'s."""
    for factory, scene, role, seed in (
        (pads_in_air_master, "pads_in_air", "master", 0),
        (pads_in_air_slave, "pads_in_air", "slave", 1),
        (probe_master, PROBE, "master", 0),
        (probe_slave, PROBE, "slave", 1),
    ):
        rig = factory()
        assert isinstance(rig, WallClockRig) and rig.inner.name == role
        ref = sim.build_rig(sim.load_scene(scene), role, seed=seed)
        clock = HandClock()
        rig._clock = clock  # the factories use time.monotonic; steer this one by hand
        rig.read()
        ref.advance(clock.step(0.02))
        assert _fields(rig.read()) == _fields(ref.read()), factory.__name__
    assert probe_master().read().contact  # the finger is on the display from t = 0
    assert not pads_in_air_master().read().contact


def test_real_clock_paces_the_plant():
    """With the default clock the plant's time is the wall time since the first read (no speed assertion:
    only that it is advanced, never ahead of the clock)."""
    import time

    rig = pads_in_air_slave()
    t0 = time.monotonic()
    rig.read()
    time.sleep(0.02)  # on purpose: the test is of the real clock, so real time must pass
    s = rig.read()
    assert 0.02 <= s.t_s <= time.monotonic() - t0


def test_sim_wallclock_imports_no_controller():
    """DESIGN §2: sim/ knows numpy, scipy and telethermo.rig only."""
    tree = ast.parse(Path(sim.__file__).with_name("wallclock.py").read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            names.add(node.module)
    tele = {
        n for n in names if n.split(".")[0] in ("telethermo", "nodes") and not n.startswith("telethermo.sim")
    }
    assert tele == {
        "telethermo.rig"
    }  # besides its own package (telethermo.sim); tests/test_layers.py checks all
