"""How fast the master's pad surface moves around trips and cuts (issue 12: ramp limit + 1 °C/s).

A telepresence pair (both control cores, both simulated rigs, the exchange of tests.stress.cases.control's
offline
timing: values sent in cycle k are used in cycle k+1) runs with the operator's finger on the master's pad; the
probe (slave) touches an object of a contact condition (:data:`CONTACTS`) from ``TOUCH_S``. At a chosen moment
after the touch one event (:data:`EVENTS`) hits the master:

- ``peer_lost``: both sides lose each other (the last values, not fresh, not alive), as a heartbeat timeout or
  a lost bus does (nodes/bus_outage.py maps a bus loss to exactly this); with the default graceful link loss
  (the master renders the identified material up to 5 s, then the envelope's peer trip);
- ``peer_lost_no_fallback``: the same with the link-loss fallback off (link_loss_render_s = 0): the peer trip
at once;
- ``peer_nan``: the slave's estimate arrives as NaN (PEER_INVALID);
- ``nmt_cut``: NMT STOP / PRE-OPERATIONAL of the master: the node cuts the drive to 0 A at once and runs no
  control cycle (nodes/runtime.py ``_on_nmt``);
- ``sensor_nan``: the master's thermocouple reads NaN (SENSOR_INVALID: cut at once, DESIGN.md §6);
- ``heat_sink_56C``: the master's heat-sink reading jumps to 56 °C (HEAT_SINK, over-temperature: cut at once).

Measured: the simulator's true pad surface (``RigTruth.T_contact_face_C``, the flux sensor's top face the
finger
touches; no controller sees it), its rate as the mean slope over a sliding :data:`WINDOW_S` window (what the
skin perceives integrates over ~0.1 s; a 10 ms difference would mostly show the sensor-noise-driven current
chatter), max |rate| over the windows ending from the event to ``AFTER_S`` after the envelope's trip (or the
cut).
Each case is run from the same state (one run up to the event, copied) three ways: the envelope's trip slew
limit on (this tree), off (the code path before it: ``trip_slew_A_per_s`` = inf, research limits), and no
event
at all (the surface's own motion in the same span: the trivial baseline).
"""

from __future__ import annotations

import copy
import dataclasses
import math

import numpy as np

from tests.stress.cases.case import Case
from tests.stress.cases.sim import load_scene_doc
from telethermo import sim
from telethermo.control.core import init_state, initial_peer, step
from telethermo.control.params import default_params
from telethermo.control.types import PeerValues, Role

PERIOD_S = 0.01
WINDOW_S = 0.1
AFTER_S = 5.0
TOUCH_S = 2.0
#: the bound: the envelope's ramp limit (5 °C/s) + 1 °C/s
RATE_LIMIT_C_PER_S = 6.0

#: contact condition -> the probe's object (None: the probe stays in the air)
CONTACTS: dict[str, dict | None] = {
    "air": None,
    "neutral_al_32C": {"material": "aluminium", "thickness_mm": 20.0, "T0_C": 32.0, "back": "adiabatic"},
    "cold_al_15C": {"material": "aluminium", "thickness_mm": 20.0, "T0_C": 15.0, "back": "adiabatic"},
    "cold_al_18C": {"material": "aluminium", "thickness_mm": 20.0, "T0_C": 18.0, "back": "adiabatic"},
    "cold_wood_15C": {"material": "oak", "thickness_mm": 20.0, "T0_C": 15.0, "back": "adiabatic"},
    "warm_al_40C": {"material": "aluminium", "thickness_mm": 20.0, "T0_C": 40.0, "back": "adiabatic"},
    "warm_wood_40C": {"material": "oak", "thickness_mm": 20.0, "T0_C": 40.0, "back": "adiabatic"},
}
EVENTS = ("peer_lost", "peer_lost_no_fallback", "peer_nan", "nmt_cut", "sensor_nan", "heat_sink_56C")
#: events whose cut is immediate by design (DESIGN.md §6: sensor plausibility, heat sink; NMT: no control)
IMMEDIATE = frozenset({"nmt_cut", "sensor_nan", "heat_sink_56C"})


def _scene(contact: str, duration_s: float):
    obj = CONTACTS[contact]
    doc = {
        "scene": {
            "name": f"slew_{contact}",
            "kind": "telepresence",
            "duration_s": duration_s,
            "period_s": PERIOD_S,
            "ambient_C": 25.0,
        },
        "master": {
            "start": "finger",
            "contacts": [{"start_s": 0.0, "end_s": duration_s + 1.0, "force_N": 8.0}],
        },
        "slave": {"start": "finger"},
        "noise": {"seed": 1},
    }
    if obj is not None:
        doc["objects"] = {"block": obj}
        doc["slave"]["contacts"] = [
            {"start_s": TOUCH_S, "end_s": duration_s + 1.0, "object": "block", "force_N": 8.0}
        ]
    return load_scene_doc(doc, f"slew_{contact}")


def _params(role: Role, rig, *, slew: bool, fallback: bool = True):
    p = default_params(role, period_s=PERIOD_S)
    lim = dataclasses.replace(p.safety, I_max_A=float(rig.I_max_A))
    if not slew:
        lim = dataclasses.replace(lim, trip_slew_A_per_s=math.inf, trip_lead_C=math.inf, research=True)
    p = dataclasses.replace(p, safety=lim)
    if not fallback:
        p = dataclasses.replace(p, link_loss_render_s=0.0)
    return p


class Pair:
    """Both cores and rigs, stepped one cycle at a time; the master's pad surface recorded after each
    advance."""

    def __init__(self, contact: str, duration_s: float) -> None:
        sc = _scene(contact, duration_s)
        self.rig_m, self.rig_s = sim.build_rig(sc, "master"), sim.build_rig(sc, "slave")
        self.pm = _params(Role.MASTER, self.rig_m, slew=True)
        self.ps = _params(Role.SLAVE, self.rig_s, slew=True)
        sm, ss = self.rig_m.read(), self.rig_s.read()
        self.st_m, self.st_s = init_state(self.pm, None, sm), init_state(self.ps, None, ss)
        self.peer_m, self.peer_s = initial_peer(sm), initial_peer(ss)
        self.surface: list[float] = []
        self.t: list[float] = []
        self.trip_at_s: float | None = None
        self.currents: list[float] = []
        self.quiet: Pair | None = None

    def cycle(self, event: str | None = None) -> None:
        sm, ss = self.rig_m.read(), self.rig_s.read()
        lost = event in ("peer_lost", "peer_lost_no_fallback", "nmt_cut")
        if lost:
            self.peer_m = dataclasses.replace(self.peer_m, fresh=False, alive=False)
            self.peer_s = dataclasses.replace(self.peer_s, fresh=False, alive=False)
        elif event == "peer_nan":
            self.peer_m = dataclasses.replace(self.peer_m, estimate_C=math.nan)
        if event == "sensor_nan":
            sm = dataclasses.replace(sm, T_sensor_C=math.nan)
        elif event == "heat_sink_56C":
            sm = dataclasses.replace(sm, T_sink_C=56.0)
        rs = step(ss, self.peer_s, self.ps, self.st_s)
        self.st_s = rs.state
        if event == "nmt_cut":  # the node runs no cycle outside OPERATIONAL: 0 A
            I_m = 0.0
            if self.trip_at_s is None:
                self.trip_at_s = sm.t_s
        else:
            rm = step(sm, self.peer_m, self.pm, self.st_m)
            self.st_m, I_m = rm.state, rm.current_A
            if not lost:
                self.peer_s = PeerValues(rm.out.estimate_C, rm.out.flux_W, contact=rm.out.contact)
            if event is not None and self.trip_at_s is None and (rm.status.safety.trips or rm.state.env.cut):
                self.trip_at_s = sm.t_s
        if not lost:
            o = rs.out
            T = math.nan if event == "peer_nan" else o.estimate_C
            self.peer_m = PeerValues(
                T,
                o.flux_W,
                contact=o.contact,
                material_code=o.material_code,
                material_beta=o.material_beta,
                material_touch=o.material_touch,
                material_T_object0_C=o.material_T_object0_C,
            )
        self.currents.append(I_m)
        self.rig_m.apply_current(I_m)
        self.rig_s.apply_current(rs.current_A)
        self.rig_m.advance(PERIOD_S)
        self.rig_s.advance(PERIOD_S)
        self.t.append(self.rig_m.t_s)
        self.surface.append(self.rig_m.truth().T_contact_face_C)

    def branch(self, *, slew: bool, fallback: bool = True) -> "Pair":
        q, self.quiet = self.quiet, None
        b = copy.deepcopy(self)
        self.quiet = q
        b.pm = _params(Role.MASTER, b.rig_m, slew=slew, fallback=fallback)
        b.ps = _params(Role.SLAVE, b.rig_s, slew=slew)
        return b


def max_rate(t: list[float], T: list[float], t0_s: float, t1_s: float, window_s: float = WINDOW_S) -> float:
    """max |T(t) - T(t - window_s)| / window_s, °C/s, over the windows inside [t0_s, t1_s]."""
    tt, TT = np.asarray(t), np.asarray(T)
    w = int(round(window_s / PERIOD_S))
    r = np.abs(TT[w:] - TT[:-w]) / window_s
    end = tt[w:]
    sel = (end >= t0_s + window_s - 1e-9) & (end <= t1_s + 1e-9)
    return float(r[sel].max()) if sel.any() else math.nan


def run_event(base: Pair, event: str | None, *, slew: bool, t_event_s: float, max_s: float = 15.0) -> dict:
    """One branch from ``base`` (at ``t_event_s``): the event until AFTER_S past the envelope's trip (or the
    cut). Rates, °C/s: ``rate_C_per_s`` from the trip to AFTER_S after it; ``rate_pre_trip_C_per_s`` from the
    event to the trip (the link-loss fallback's rendering: no trip yet), NaN when the trip came at once."""
    p = base.branch(slew=slew, fallback=event != "peer_lost_no_fallback")
    n0 = len(p.t)
    while True:
        p.cycle(event)
        tr = p.trip_at_s
        if (tr is not None and p.t[-1] >= tr + AFTER_S) or p.t[-1] >= t_event_s + max_s:
            break
    t_trip = p.trip_at_s if p.trip_at_s is not None else t_event_s
    I = np.asarray(p.currents[n0 - 1 :])
    pre = max_rate(p.t, p.surface, t_event_s, t_trip) if t_trip - t_event_s >= 2 * WINDOW_S else math.nan
    return {
        "rate_C_per_s": max_rate(p.t, p.surface, t_trip, t_trip + AFTER_S),
        "rate_pre_trip_C_per_s": pre,
        "trip_after_s": None if p.trip_at_s is None else round(p.trip_at_s - t_event_s, 3),
        "max_current_step_A": float(np.abs(np.diff(I)).max()) if len(I) > 1 else 0.0,
        "t_trip_s": t_trip,
    }


def sweep(contacts=tuple(CONTACTS), events=EVENTS, after_touch_s=(0.5, 0.7, 2.0, 5.0)) -> list[dict]:
    """Every (contact, moment after the touch, event): the rates with the slew limit on, off, and no event."""
    rows = []
    for contact in contacts:
        for dt_touch in after_touch_s:
            t_ev = TOUCH_S + dt_touch
            base = Pair(contact, t_ev + 25.0)
            while base.rig_m.t_s < t_ev - 1e-9:
                base.cycle()
            for event in events:
                on = run_event(base, event, slew=True, t_event_s=t_ev)
                off = run_event(base, event, slew=False, t_event_s=t_ev)
                t0 = on["t_trip_s"]
                none = max_rate(*_quiet(base, t0 + AFTER_S), t0, t0 + AFTER_S)
                fb_none = (
                    max_rate(*_quiet(base, t0), t_ev, t0)
                    if math.isfinite(on["rate_pre_trip_C_per_s"])
                    else math.nan
                )  # the surface's own motion over the fallback's span
                rows.append(
                    {
                        "contact": contact,
                        "event": event,
                        "after_touch_s": dt_touch,
                        "immediate_cut": event in IMMEDIATE,
                        "trip_after_s": on["trip_after_s"],
                        "rate_slew_C_per_s": on["rate_C_per_s"],
                        "rate_before_C_per_s": off["rate_C_per_s"],
                        "rate_no_event_C_per_s": none,
                        "rate_fallback_C_per_s": on["rate_pre_trip_C_per_s"],
                        "rate_fallback_before_C_per_s": off["rate_pre_trip_C_per_s"],
                        "rate_fallback_no_event_C_per_s": fb_none,
                        "max_current_step_slew_A": on["max_current_step_A"],
                        "max_current_step_before_A": off["max_current_step_A"],
                    }
                )
    return rows


def _quiet(base: Pair, t1_s: float) -> tuple[list[float], list[float]]:
    """The same pair with no event up to ``t1_s`` (kept on ``base``; extended when a later end is asked)."""
    q = getattr(base, "quiet", None)
    if q is None or q.t[-1] < t1_s - 1e-9:
        q = base.branch(slew=True)
        while q.t[-1] < t1_s - 1e-9:
            q.cycle()
        base.quiet = q
    return q.t, q.surface


def _worst(rows: list[dict], key: str, pick) -> tuple[float, dict | None]:
    sel = [r for r in rows if pick(r) and math.isfinite(r[key])]
    if not sel:
        return math.nan, None
    r = max(sel, key=lambda r: r[key])
    return r[key], {k: r[k] for k in ("contact", "event", "after_touch_s")}


def case_surface_rate(contacts=tuple(CONTACTS), events=EVENTS, after_touch_s=(0.5, 0.7, 2.0, 5.0)) -> dict:
    """The pad surface's rate around trips and cuts: at most the ramp limit + 1 °C/s where the physics
    allows."""
    c = Case(
        "control_trip_surface_rate",
        f"a telepresence pair, the finger on the master, the probe in air or touching an object "
        f"({', '.join(contacts)}); {', '.join(str(x) for x in after_touch_s)} s after the touch the master "
        f"meets one of {', '.join(events)}: the true pad surface (mean slope over {WINDOW_S:g} s) moves at "
        f"most {RATE_LIMIT_C_PER_S:g} °C/s (ramp limit + 1) from the peer trip to {AFTER_S:g} s after it, "
        "unless the surface moves faster than that with no event at all (the contact's own transient); the "
        "immediate cuts (NMT, sensor NaN, heat sink) are measured, not bounded (the pad's stored heat)",
    )
    rows = sweep(contacts, events, after_touch_s)
    c.fig(
        surface_rate_cases=rows,
        window_s=WINDOW_S,
        after_s=AFTER_S,
        surface_rate_limit_C_per_s=RATE_LIMIT_C_PER_S,
    )
    for key, label in (
        ("rate_slew_C_per_s", "slew"),
        ("rate_before_C_per_s", "before"),
        ("rate_no_event_C_per_s", "no_event"),
    ):
        for name, pick in (
            ("peer_trips", lambda r: not r["immediate_cut"]),
            ("immediate_cuts", lambda r: r["immediate_cut"]),
        ):
            v, where = _worst(rows, key, pick)
            c.fig(**{f"max_{label}_{name}_C_per_s": v, f"max_{label}_{name}_at": where})
    v, where = _worst(rows, "rate_fallback_C_per_s", lambda r: True)
    c.fig(max_fallback_phase_C_per_s=v, max_fallback_phase_at=where)
    for r in rows:
        if r["immediate_cut"]:
            continue
        allowed = max(RATE_LIMIT_C_PER_S, r["rate_no_event_C_per_s"])
        c.require(
            r["rate_slew_C_per_s"] <= allowed,
            f"{r['contact']} +{r['after_touch_s']} s {r['event']}: surface {r['rate_slew_C_per_s']:.2f} °C/s "
            f"after the trip <= {allowed:.2f} °C/s (before the slew: {r['rate_before_C_per_s']:.2f})",
        )
    for r in rows:  # the link-loss fallback (issue 15: the master renders the identified material before any
        # trip) is slewed and lead-bounded as a peer trip is: bounded the same way, against the surface's own
        # motion over the fallback's span
        if math.isfinite(r["rate_fallback_C_per_s"]):
            allowed = max(RATE_LIMIT_C_PER_S, r["rate_fallback_no_event_C_per_s"])
            c.require(
                r["rate_fallback_C_per_s"] <= allowed,
                f"{r['contact']} +{r['after_touch_s']} s {r['event']}: surface "
                f"{r['rate_fallback_C_per_s']:.2f} "
                f"°C/s during the link-loss fallback <= {allowed:.2f} °C/s (before the slew: "
                f"{r['rate_fallback_before_C_per_s']:.2f})",
            )
    quiet = [r for r in rows if r["rate_no_event_C_per_s"] <= RATE_LIMIT_C_PER_S]
    head = {}
    for key, sel in (
        ("", lambda r: not r["immediate_cut"] and r in quiet),
        ("_all_peer_trips", lambda r: not r["immediate_cut"]),
        ("_immediate_cut", lambda r: r["immediate_cut"] and r in quiet),
        ("_immediate_cut_all", lambda r: r["immediate_cut"]),
    ):
        head[f"surface_rate_max{key}_C_per_s"] = _worst(rows, "rate_slew_C_per_s", sel)[0]
        head[f"surface_rate_max{key}_before_C_per_s"] = _worst(rows, "rate_before_C_per_s", sel)[0]
    head["surface_rate_max_no_event_C_per_s"] = _worst(rows, "rate_no_event_C_per_s", lambda r: True)[0]
    head["surface_rate_max_fallback_phase_C_per_s"] = _worst(rows, "rate_fallback_C_per_s", lambda r: True)[0]
    head["surface_rate_max_fallback_phase_before_C_per_s"] = _worst(
        rows, "rate_fallback_before_C_per_s", lambda r: True
    )[0]
    fb_quiet = lambda r: r["rate_fallback_no_event_C_per_s"] <= RATE_LIMIT_C_PER_S  # noqa: E731
    head["surface_rate_max_fallback_phase_quiet_C_per_s"] = _worst(rows, "rate_fallback_C_per_s", fb_quiet)[0]
    head["surface_rate_max_fallback_phase_quiet_before_C_per_s"] = _worst(
        rows, "rate_fallback_before_C_per_s", fb_quiet
    )[0]
    head["surface_rate_limit_C_per_s"] = RATE_LIMIT_C_PER_S
    head["surface_rate_cases"] = [
        [
            r["contact"],
            r["event"],
            r["after_touch_s"],
            round(r["rate_slew_C_per_s"], 3),
            round(r["rate_before_C_per_s"], 3),
            round(r["rate_no_event_C_per_s"], 3),
        ]
        for r in rows
    ]
    head["surface_rate_cases_columns"] = [
        "contact",
        "event",
        "after_touch_s",
        "slew_C_per_s",
        "before_C_per_s",
        "no_event_C_per_s",
    ]
    head["surface_rate_how"] = (
        f"tests/stress/cases/slew.py: max |slope| of the simulated master pad surface over {WINDOW_S:g} s "
        f"windows, trip to +{AFTER_S:g} s; surface_rate_max_C_per_s over the peer trips where the "
        "contact alone moves the surface <= the limit (else *_all_*)"
    )
    res = c.result()
    res["headline"] = head
    return res


CASES = {
    "control_trip_surface_rate": (
        case_surface_rate,
        {},
        {"contacts": ("air", "cold_al_18C", "warm_al_40C", "cold_wood_15C"), "after_touch_s": (0.5, 5.0)},
    )
}
