"""osc_guard_C (0x2204), the slave's oscillation guard threshold on the bus: the value a node shows and an
SDO write sets goes, through nodes/odparams.py's mapping (ParamBook, od_image), into the CoreParams the
control core steps with, and the core's guard fires on it (telethermo.control.osc_guard)."""

from __future__ import annotations

import math

import pytest

from telethermo.bus_config.partable import BY_NAME
from telethermo.control.core import init_state, step
from telethermo.control.osc_guard import DETUNE
from telethermo.control.params import default_params
from telethermo.control.rendering import load_render_table
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


def _guard_after_ring(params, seconds: float = 4.0) -> tuple[int, float]:
    """Step the core in contact against a finger estimate ringing ±RING_C at 1 Hz on 33 °C: the guard's
    detections and its kp scale at the end."""
    dt = params.period_s
    st = init_state(params, None, RigSample(0.0, 33.0, 0.0, 0.0, True, 26.0))
    for k in range(int(seconds / dt)):
        t = k * dt
        finger = 33.0 + RING_C * math.sin(2 * math.pi * 1.0 * t)
        r = step(RigSample(t, 33.0, 0.0, 0.0, True, 26.0), PeerValues(finger, 0.0), params, st)
        st = r.state
    return st.osc.detections, st.osc.scale


def test_the_slave_shows_its_guard_threshold_and_the_master_its_guard_off():
    assert _image(_book(Role.SLAVE))["osc_guard_C"] == default_params(Role.SLAVE).osc_guard_C == 0.15
    assert _image(_book(Role.MASTER))["osc_guard_C"] == default_params(Role.MASTER).osc_guard_C == 0.0
    p = BY_NAME["osc_guard_C"]
    assert (p.value("low", "slave"), p.value("high", "slave"), p.value("default", "slave")) == (
        0.0,
        1.0,
        0.15,
    )
    assert p.value("high", "master") == 0.0 and p.stored


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
