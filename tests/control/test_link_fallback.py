"""Graceful link loss (telethermo.control.link_fallback through the core): when it renders, for how long, what
it renders, the envelope around it, and the bumpless return to telepresence. No plant: constant samples."""

from __future__ import annotations

import dataclasses
import math

import pytest
from hypothesis import given, settings, strategies as st

from telethermo.control.core import CoreParams, init_state, step
from telethermo.control.later_phase import LaterModel
from telethermo.control.link_fallback import LinkState, link_step, object_temperature
from telethermo.control.material_stream import UNKNOWN_CODE
from telethermo.control.params import default_params
from telethermo.control.rendering import contact_temperature
from telethermo.control.safety import SafetyState, Trip
from telethermo.control.types import Mode, PeerValues, Role
from telethermo.nodes.odparams import ParamBook, od_image
from telethermo.rig import RigSample

DT = 0.01
P = CoreParams(role=Role.MASTER, kp_A_per_C=0.8, ki_A_per_C_s=1.0, link_loss_render_s=0.5)
STEEL_CODE = 6  # any material of the rendering table


def S(k, T=30.0, Q=0.3, I=0.0, contact=True, sink=26.0):
    return RigSample(k * DT, T, Q, I, contact, sink)


def peer(est=27.0, *, contact=True, alive=True, code=STEEL_CODE, beta=8.0, touch=1, fresh=True):
    return PeerValues(
        est,
        -0.4,
        fresh=fresh,
        alive=alive,
        contact=contact,
        material_code=code,
        material_beta=beta,
        material_touch=touch,
    )


def run(params, schedule, state=None, k0=0):
    """Step through ``schedule`` (a list of (sample, peer)); the results."""
    state = state or init_state(params, None, schedule[0][0])
    out = []
    for smp, pv in schedule:
        r = step(smp, pv, params, state)
        state = r.state
        out.append(r)
    return out


def touch_then_loss(n_link=60, n_loss=100, params=P, **pk):
    """The probe in the air (finger at 33 °C on the pad), then touching (identified), then the link lost."""
    sched = [(S(k, T=33.0, Q=0.0), peer(33.0, contact=False, code=0, touch=0)) for k in range(20)]
    sched += [(S(20 + k), peer(**pk)) for k in range(n_link)]
    last = peer(**pk)
    sched += [
        (S(20 + n_link + k), dataclasses.replace(last, alive=False, fresh=False)) for k in range(n_loss)
    ]
    return run(params, sched)


def test_eq1_inverted_gives_back_the_surface_temperature():
    T_o0 = object_temperature(33.0, 27.0, 8.0)
    assert contact_temperature(33.0, 1.0, T_o0, 8.0) == pytest.approx(27.0)
    assert object_temperature(math.nan, 27.0, 8.0) == 27.0


def test_fallback_renders_for_the_configured_time_then_neutral_as_before():
    res = touch_then_loss()
    loss = res[80:]
    n_fb = round(P.link_loss_render_s / DT) + 1  # the start step, then render_s
    assert [r.status.link_fallback for r in loss[:n_fb]] == [True] * n_fb
    assert loss[0].status.link_fallback_started and not any(r.status.link_fallback_started for r in loss[1:])
    assert all(Trip.PEER_LOST not in r.status.trips for r in loss[:n_fb])
    assert all(r.current_A != 0.0 for r in loss[:n_fb])
    # the render starts at the surface temperature the slave sent last (eq. 1 of the inverted object)
    assert loss[0].status.requested_setpoint_C == pytest.approx(27.0, abs=1e-6)
    after = loss[n_fb]
    assert not after.status.link_fallback and Trip.PEER_LOST in after.status.safety.new_trips
    assert after.status.safety.state is SafetyState.RAMP_TO_NEUTRAL


def test_disabled_or_nothing_identified_ramps_to_neutral_at_once():
    for res in (
        touch_then_loss(params=dataclasses.replace(P, link_loss_render_s=0.0)),
        touch_then_loss(code=0),
    ):
        assert not any(r.status.link_fallback for r in res)
        assert Trip.PEER_LOST in res[80].status.safety.new_trips


def test_no_fallback_without_the_finger_or_with_the_probe_in_the_air():
    st0 = LinkState(
        touch=1,
        touching=True,
        T_finger0_C=33.0,
        T_surface_C=27.0,
        code=STEEL_CODE,
        beta=8.0,
        id_touch=1,
        peer_touch=1,
    )
    kw = dict(
        peer_usable=False,
        est_C=27.0,
        q_in_W=0.3,
        T_surface_est_C=27.0,
        render_s=1.0,
        dt_s=DT,
        peer_tripped=False,
    )
    lost = peer(alive=False)
    assert link_step(st0, lost, contact=True, **kw).active
    assert not link_step(st0, lost, contact=False, **kw).active
    assert not link_step(st0, dataclasses.replace(lost, contact=False), contact=True, **kw).active
    assert not link_step(st0, lost, contact=True, **{**kw, "peer_tripped": True}).active
    # an identification older than the previous touch is not rendered
    assert not link_step(dataclasses.replace(st0, touch=3, id_touch=1), lost, contact=True, **kw).active
    assert link_step(dataclasses.replace(st0, touch=2, id_touch=1), lost, contact=True, **kw).active


def test_fallback_ends_when_the_finger_leaves():
    p5 = dataclasses.replace(P, link_loss_render_s=5.0)
    res = touch_then_loss(n_loss=20, params=p5)
    state = res[-1].state
    assert res[-1].status.link_fallback
    lifted = run(
        p5,
        [(S(120 + k, contact=False, Q=0.0), peer(alive=False, fresh=False)) for k in range(60)],
        state=state,
    )
    ends = [r.status.link_fallback for r in lifted].index(False)  # once the contact detector releases (< 5 s)
    assert not any(r.status.link_fallback for r in lifted[ends:])
    assert Trip.PEER_LOST in lifted[ends].status.safety.new_trips


def test_bumpless_return_when_the_link_comes_back():
    res = touch_then_loss(n_loss=30)
    state, prev = res[-1].state, res[-1]
    assert prev.status.link_fallback
    back = run(P, [(S(130 + k), peer(est=29.0)) for k in range(200)], state=state)
    assert not back[0].status.link_fallback and not back[0].status.trips
    assert abs(back[0].current_A - prev.current_A) < 0.05  # PI re-seeded on the switch
    sps = [prev.status.setpoint_C] + [r.status.setpoint_C for r in back]
    assert max(abs(b - a) for a, b in zip(sps, sps[1:])) <= P.safety.ramp_up_C_per_s * DT + 1e-9
    assert back[-1].status.setpoint_C == pytest.approx(29.0)  # telepresence again


finite_T = st.floats(-30.0, 100.0)
any_T = st.one_of(finite_T, st.sampled_from([math.nan, math.inf, -math.inf, 1e6]))


@settings(max_examples=60, deadline=None)
@given(
    est=any_T,
    beta=st.one_of(st.floats(1e-3, 1e3), st.sampled_from([math.nan, 0.0, -1.0])),
    code=st.integers(0, 20),
    render_s=st.floats(0.0, 2.0),
    T_sensor=st.floats(10.0, 45.0),
    Q=st.floats(-5.0, 5.0),
    finger=st.floats(20.0, 40.0),
    n_loss=st.integers(1, 250),
)
def test_link_loss_during_a_touch_keeps_the_envelope(est, beta, code, render_s, T_sensor, Q, finger, n_loss):
    """Whatever the slave sent last and however long the fallback may render: the setpoint stays within
    [T_min, T_max] and its ramp limit, the current within its limit, and the loss ends neutral and cut."""
    params = dataclasses.replace(P, link_loss_render_s=render_s)
    lim = params.safety
    sched = [(S(k, T=finger, Q=0.0), peer(finger, contact=False, code=0, touch=0)) for k in range(10)]
    sched += [(S(10 + k, T=T_sensor, Q=Q), peer(est, code=code, beta=beta)) for k in range(40)]
    lost = dataclasses.replace(sched[-1][1], alive=False, fresh=False)
    sched += [(S(50 + k, T=T_sensor, Q=Q), lost) for k in range(n_loss)]
    res = run(params, sched)
    sps = [r.status.setpoint_C for r in res]
    for r in res:
        assert lim.T_min_C <= r.status.setpoint_C <= lim.T_max_C
        assert math.isfinite(r.current_A) and abs(r.current_A) <= lim.I_limit_A + 1e-12
    steps = [b - a for a, b in zip(sps, sps[1:])]
    assert max(steps) <= lim.ramp_up_C_per_s * DT + 1e-9 and min(steps) >= -lim.ramp_down_C_per_s * DT - 1e-9
    fb = [r.status.link_fallback for r in res[50:]]
    assert sum(fb) <= round(render_s / DT) + 1 and fb == sorted(
        fb, reverse=True
    )  # one episode, from the loss
    if not fb[-1]:
        assert Trip.PEER_LOST in res[-1].status.trips or Trip.PEER_INVALID in res[-1].status.trips


def test_link_loss_render_s_is_an_od_parameter_of_the_node():
    """0x2618 link_loss_render_s: a node's SDO write reaches CoreParams (all modes), the OD image shows it,
    and an
    out-of-range value is refused (CoreParams' own check: the EDS range is 0..60 s)."""

    def params_for(mode, render=None):
        return (
            default_params(Role.MASTER, mode=mode, render=render)
            if render is not None
            else default_params(Role.MASTER, mode=mode)
        )

    book = ParamBook(
        Role.MASTER, params_for, has_model=False, table={"wood": 0.4}, od_material=(1, 0.4, 25.0)
    )
    assert book.params().link_loss_render_s == 5.0
    assert book.check("link_loss_render_s", 2.5) is None
    book.apply("link_loss_render_s", 2.5)
    assert book.params().link_loss_render_s == 2.5 and book.params(Mode.IDLE).link_loss_render_s == 2.5
    assert od_image(book.params(), None, material_code=0, peer_miss_limit=10)["link_loss_render_s"] == 2.5
    assert book.check("link_loss_render_s", 61.0) is not None


def test_an_abstained_identification_renders_the_fitted_effusivity_never_a_class():
    """The slave said "unknown" (issue 23) but fitted β and the object: the fallback renders that β on a
    semi-infinite object (no class's block); "unknown" without an effusivity renders nothing."""
    res = touch_then_loss(code=UNKNOWN_CODE, beta=8.0)
    loss = res[80:]
    assert loss[0].status.link_fallback and loss[0].status.requested_setpoint_C == pytest.approx(
        27.0, abs=1e-6
    )
    lp, _ = loss[1].state.link.later
    assert lp.model is LaterModel.SEMI_INFINITE and lp.obj is None
    assert loss[1].state.link.code == UNKNOWN_CODE and loss[1].state.link.beta == 8.0
    none = touch_then_loss(code=UNKNOWN_CODE, beta=math.nan)[80:]
    assert not any(r.status.link_fallback for r in none)
