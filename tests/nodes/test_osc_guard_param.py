"""osc_guard_C (0x2204), the oscillation guard threshold of either side on the bus: the value a node shows
and an SDO write sets goes, through nodes/odparams.py's mapping (ParamBook, od_image), into the CoreParams the
control core steps with, and the core's guard fires on it (telethermo.control.osc_guard)."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from telethermo.bus_config.partable import BY_NAME
from telethermo.control.core import init_state, step
from telethermo.control.osc_guard import DETUNE, detuned
from telethermo.control.params import default_params
from telethermo.control.rendering import load_render_table
from telethermo.control.contact import ContactParams, ContactSource
from telethermo.control.core import RenderSettings
from telethermo.control.types import Mode, PeerValues, Role
from telethermo.nodes.odparams import ParamBook, od_image
from telethermo.rig import RigSample

RING_C = 0.25  # amplitude of the finger estimate's ring, °C: its band peak lies between 0.15 and 0.3 °C


def _book(role: Role = Role.SLAVE) -> ParamBook:
    def params_for(mode, render=None):
        return default_params(role, mode=mode)

    return ParamBook(role, params_for, has_model=False, table=load_render_table(), od_material=(1, 0.4, 25.0))


def _image(book: ParamBook) -> dict:
    return od_image(book.params(), None, material_code=0, peer_miss_limit=book.peer_miss_limit)


def _guard_after_ring(
    params, seconds: float = 4.0, ring_C: float = RING_C, own: bool = False
) -> tuple[int, float]:
    """Step the core in contact against a peer estimate ringing ±``ring_C`` at 1 Hz on 33 °C (``own``: the
    peer steady, the rig's own sensor ringing instead): the guards' detections and the kp scale at the end."""
    dt = params.period_s
    st = init_state(params, None, RigSample(0.0, 33.0, 0.0, 0.0, True, 26.0))
    for k in range(int(seconds / dt)):
        t = k * dt
        ring = ring_C * math.sin(2 * math.pi * 1.0 * t)
        T_own, peer = (33.0 + ring, 33.0) if own else (33.0, 33.0 + ring)
        r = step(RigSample(t, T_own, 0.0, 0.0, True, 26.0), PeerValues(peer, 0.0), params, st)
        st = r.state
    return st.osc.detections + st.osc_own.detections, min(st.osc.scale, st.osc_own.scale)


def test_each_side_shows_its_guard_threshold():
    assert _image(_book(Role.SLAVE))["osc_guard_C"] == default_params(Role.SLAVE).osc_guard_C == 0.15
    assert _image(_book(Role.MASTER))["osc_guard_C"] == default_params(Role.MASTER).osc_guard_C == 0.3
    p = BY_NAME["osc_guard_C"]
    for role, default in (("slave", 0.15), ("master", 0.3)):
        assert (p.value("low", role), p.value("high", role), p.value("default", role)) == (0.0, 1.0, default)
    assert p.stored


@pytest.mark.parametrize("own", [False, True])
def test_the_master_guards_on_the_probe_estimate_and_on_its_own_skin_estimate(own):
    """The display's guard (default 0.3 °C) fires on a ring of the probe's estimate it tracks and on a ring of
    its own skin estimate (its own loop, which the probe's estimate need not show), not on a smaller one,
    and it never runs in render mode (no peer, and the render's own loop is not the exchange's)."""
    # the rig's contact flag decides contact here (the display's own detector reads the flux, held at 0 W)
    params = replace(
        default_params(Role.MASTER, mode=Mode.TELEPRESENCE), contact=ContactParams(source=ContactSource.FLAG)
    )
    assert _guard_after_ring(params, ring_C=0.5, own=own) == (1, DETUNE)
    assert _guard_after_ring(params, ring_C=0.2, own=own) == (0, 1.0)
    render = replace(params, mode=Mode.RENDER, render=RenderSettings(beta_object=0.74, T_object0_C=25.0))
    assert render.osc_guard_C == 0.3 and _guard_after_ring(render, ring_C=0.5, own=own) == (0, 1.0)


def test_the_display_detunes_kp_and_ki_the_probe_kp_alone():
    """After a ring the display's PI keeps its zero (kp and ki scaled alike), the probe's ki is kept."""
    assert detuned(1.6, 0.04, DETUNE, master=True) == (1.6 * DETUNE, 0.04 * DETUNE)
    assert detuned(0.43, 0.12, DETUNE, master=False) == (0.43 * DETUNE, 0.12)
    assert detuned(0.43, 0.12, 1.0, master=True) == (0.43, 0.12)


@pytest.mark.parametrize("written_C, fires", [(None, True), (0.3, False), (0.0, False), (0.2, True)])
def test_the_core_guards_with_the_written_threshold_in_every_mode(written_C, fires):
    """A write reaches the parameters of every mode the slave runs (scope: all modes) and the core's guard
    uses it: a ring whose band peaks between 0.15 and 0.3 °C fires at the default 0.15 and at 0.2, not at
    0.3, and not when the guard is off (0)."""
    book = _book()
    if written_C is not None:
        assert book.check("osc_guard_C", written_C) is None
        book.apply("osc_guard_C", written_C)
        assert _image(book)["osc_guard_C"] == written_C
    threshold = 0.15 if written_C is None else written_C
    for mode in (Mode.IDLE, Mode.TELEPRESENCE, Mode.IDENTIFY):
        assert book.params(mode).osc_guard_C == threshold, mode
    detections, scale = _guard_after_ring(book.params(Mode.TELEPRESENCE))
    assert (detections, scale) == ((1, DETUNE) if fires else (0, 1.0))
