"""Offline session: scene + both controllers + both simulated rigs + the direct-touch reference, lockstep.

    from telethermo.offline import run_offline_session, write_session
    res = run_offline_session("probe_touches_al_steel_wood")
    write_session("out/session", res)            # recording.csv, summary.json, session.png (atomic)

One step k (what the two nodes do on SYNC k, see docs/control.md "exchange timing"):

1. each rig is read: sample_k (time t_k);
2. each controller steps with the peer values *sent in cycle k-1* (TPDO1 of the previous SYNC; in
   cycle 0, :func:`telethermo.control.core.initial_peer`), optionally rounded to REAL32;
3. each rig gets its current and every simulation (both rigs, the reference) advances by one period.

Render sessions (``mode="render"``): the master alone renders the virtual materials of the scene's
touches (yamamoto), the reference is the finger touching the real material.
"""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from telethermo.atomic import write_json_atomic
from telethermo.control.core import CoreParams, init_state, initial_peer, step
from telethermo.control.defaults import HOLD_GAINS
from telethermo.control.detach import tem_limits
from telethermo.control.later_phase import DEFAULT_LATER_MODEL
from telethermo.control.params import default_params
from telethermo.control.types import Mode, Outgoing, PeerValues, Role
from telethermo.offline.figures import compute_figures
from telethermo.offline.plot import write_session_png
from telethermo.recording.format import Recording, RecordingBuilder, write_recording_csv
from telethermo.recording.rows import finger_skin_C, ref_row, scene_contacts, side_row, truth_row
from telethermo.offline.render_script import RenderScript
from telethermo import sim
from telethermo.ident import load_model

ROUNDINGS = ("none", "real32")


def round_real32(x: float) -> float:
    """The value a REAL32 PDO carries (IEEE 754 single, round to nearest)."""
    return float(np.float32(x))


@dataclass
class SessionResult:
    """A finished session: the recording and its figures."""

    recording: Recording
    figures: dict[str, Any]


def _load_model(model: Any) -> Any:
    if model is None or not isinstance(model, (str, os.PathLike)):
        return model
    return load_model(model)


def run_offline_session(
    scene: Any,
    *,
    master_params: CoreParams | None = None,
    slave_params: CoreParams | None = None,
    master_model: Any = None,
    slave_model: Any = None,
    duration_s: float | None = None,
    rounding: str = "none",
    seed: int | None = 0,
    mode: str | None = None,
    render_options: dict[str, Any] | None = None,
    peer_loss_s: tuple[float, float] | None = None,
    slave_rig_params: Any = None,
    delay_cycles: int = 0,
    delay_jitter_cycles: int = 0,
    rig_path: Callable[[Any, str], Any] | None = None,
) -> SessionResult:
    """Run a scene offline and return the recording and its figures.

    ``scene``: a name or path (``sim.load_scene``) or a loaded scene. ``*_params``: controller
    parameters (default: :func:`telethermo.control.params.default_params` for the scene's period).
    ``*_model``: a TEM model, a model file path, a predictor, or None (FLUX estimator needs none).
    ``rounding``: "none" or "real32" (exchanged values rounded as REAL32 PDOs carry them).
    ``mode``: "telepresence" or "render" (default: render for a "virtual" scene).
    ``render_options``: ``beta_pad`` (the calibrated pad β), ``T_finger0_C``, ``finger_thermometer``,
    ``thermometer_lead_s``, ``later_model``, ``table`` (see :func:`_run_render`).
    ``peer_loss_s``: (telepresence) a scripted link loss (start, end), s: the samples of cycles at
    start <= t < end see their peer lost (the last values received, not fresh, not alive), as a node does
    once its heartbeat consumer or the PDO-miss limit declares the peer lost.
    ``slave_rig_params``: (telepresence) the probe's own rig (a ``sim.tem.RigParams``; default: the scene's).
    ``delay_cycles``, ``delay_jitter_cycles``: extra one-way transport delay of the exchanged values, in
    cycles, on both streams: each value arrives ``delay_cycles`` plus a uniform 0..jitter cycles late (seeded
    by ``seed``), never before a value sent earlier (CAN keeps the order); the peer uses the newest arrived.
    ``rig_path``: (telepresence) ``rig_path(rig, role)`` returns what the controller of ``role`` drives
    instead of the simulated rig itself, e.g. the rig behind simulated I/O modules (bench.io_rig_bench); it
    keeps the rig's ``truth``/``bodies``/``t_s`` for the recording.
    """
    sc, mode = _scene_and_mode(scene, mode, rounding)
    rig_m = sim.build_rig(sc, "master", seed=seed)
    period = rig_m.period_s
    T_end = float(duration_s if duration_s is not None else sc.duration_s)
    n_steps = int(round(T_end / period))
    rnd = round_real32 if rounding == "real32" else (lambda x: x)
    ref = sim.build_reference(sc)

    if mode == "render":  # the master alone: it renders the touches' materials, or holds its pad
        lone = _run_render if any(t.render is not None for t in sc.master_contacts) else _run_hold
        model_m, opts = _load_model(master_model), render_options or {}
        return lone(sc, rig_m, ref, master_params, model_m, n_steps, period, rounding, **opts)

    sc_s = sc if slave_rig_params is None else dataclasses.replace(sc, rig_params=slave_rig_params)
    rig_s = sim.build_rig(sc_s, "slave", seed=None if seed is None else seed + 1)
    if rig_path is not None:
        rig_m, rig_s = rig_path(rig_m, "master"), rig_path(rig_s, "slave")
    models = (_load_model(master_model), _load_model(slave_model))
    link = _DelayLine(delay_cycles, delay_jitter_cycles, seed)
    rigs, params = (rig_m, rig_s), (master_params, slave_params)
    return _run_telepresence(sc, rigs, ref, params, models, n_steps, rnd, rounding, seed, peer_loss_s, link)


def _scene_and_mode(scene: Any, mode: str | None, rounding: str) -> tuple[Any, str]:
    """The loaded scene and the session's mode ("render" for a virtual scene unless given), after
    checking ``rounding`` and ``mode`` (ValueError naming the argument)."""
    if rounding not in ROUNDINGS:
        raise ValueError(f"run_offline_session: rounding: expected one of {ROUNDINGS}, got {rounding!r}")
    sc = sim.load_scene(scene) if isinstance(scene, (str, os.PathLike)) else scene
    if mode is None:
        mode = "render" if sc.kind == "virtual" else "telepresence"
    if mode not in ("telepresence", "render"):
        raise ValueError(f"run_offline_session: mode: expected 'telepresence' or 'render', got {mode!r}")
    return sc, mode


def _run_telepresence(
    sc,
    rigs: tuple[Any, Any],
    ref,
    params: tuple[CoreParams | None, CoreParams | None],
    models: tuple[Any, Any],
    n_steps: int,
    rnd,
    rounding: str,
    seed: int | None,
    peer_loss_s,
    link: "_DelayLine",
) -> SessionResult:
    """Both sides in lockstep (see the module docstring): ``rigs``, ``params`` (None: the defaults) and
    ``models`` are (master's, slave's)."""
    (rig_m, rig_s), (master_params, slave_params), (model_m, model_s) = rigs, params, models
    period = rig_m.period_s
    if rig_s.period_s != period:
        raise ValueError(f"run_offline_session: the rigs' periods differ ({period} s vs {rig_s.period_s} s)")
    pm = master_params or default_params(Role.MASTER, period_s=period)
    ps = slave_params or default_params(Role.SLAVE, period_s=period)
    for name, p in (("master_params", pm), ("slave_params", ps)):
        if abs(p.period_s - period) > 1e-12:
            raise ValueError(
                f"run_offline_session: {name}.period_s = {p.period_s} s but the rig runs at {period} s"
            )
    pm, ps = _with_rig_limits(pm, rig_m), _with_rig_limits(ps, rig_s)
    sm0, ss0 = rig_m.read(), rig_s.read()
    st_m = init_state(pm, model_m, sm0)
    st_s = init_state(ps, model_s, ss0)
    peer_m, peer_s = initial_peer(sm0), initial_peer(ss0)

    meta = {
        "scene": getattr(sc, "name", ""),
        "period_s": period,
        "mode": "telepresence",
        "rounding": rounding,
        "seed": seed,
        "contacts": scene_contacts(sc, "slave"),
        "master_params": _params_meta(pm),
        "slave_params": _params_meta(ps),
    }
    b = RecordingBuilder(meta)
    for _k in range(n_steps):
        sm, ss = rig_m.read(), rig_s.read()
        if peer_loss_s is not None and peer_loss_s[0] <= sm.t_s < peer_loss_s[1]:
            peer_m, peer_s = _lost(peer_m), _lost(peer_s)
        rm = step(sm, peer_m, pm, st_m)
        rs = step(ss, peer_s, ps, st_s)
        row = {"t_s": sm.t_s}
        row.update(side_row("m", sm, rm, peer_m))
        row.update(side_row("s", ss, rs, peer_s))
        row.update(truth_row("m", rig_m))
        row.update(truth_row("s", rig_s))
        row.update(ref_row(ref))
        b.add(row)
        st_m, st_s = rm.state, rs.state
        # values sent in this cycle, received by the peer in the next one (later with a delay line)
        peer_m, peer_s = link.pass_on(_k, _received(rs.out, rnd), _received(rm.out, rnd), peer_m, peer_s)
        rig_m.apply_current(rm.current_A)
        rig_s.apply_current(rs.current_A)
        rig_m.advance(period)
        rig_s.advance(period)
        ref.advance(period)
    rec = b.build()
    return SessionResult(rec, compute_figures(rec))


def _received(out: Outgoing, rnd) -> PeerValues:
    """What the peer receives of ``out`` in the next cycle (TPDO1 and the contact PDO; REAL32 with
    ``rnd``)."""
    return PeerValues(
        rnd(out.estimate_C),
        rnd(out.flux_W),
        contact=out.contact,
        material_code=out.material_code,
        material_beta=rnd(out.material_beta),
        material_touch=out.material_touch,
        material_T_object0_C=rnd(out.material_T_object0_C),
    )


class _DelayLine:
    """Extra transport delay of both PDO streams, in cycles, with jitter (order kept, newest arrived wins)."""

    def __init__(self, cycles: int, jitter: int, seed: int | None) -> None:
        if cycles < 0 or jitter < 0:
            raise ValueError(
                f"run_offline_session: delay_cycles/delay_jitter_cycles: expected >= 0, got {cycles}/{jitter}"
            )
        self.cycles, self.jitter = int(cycles), int(jitter)
        self.rng = np.random.default_rng(None if seed is None else seed + 7)
        self.queue: list[tuple[int, PeerValues, PeerValues]] = []
        self.last_due = -1

    def pass_on(
        self, k: int, to_m: PeerValues, to_s: PeerValues, cur_m: PeerValues, cur_s: PeerValues
    ) -> tuple[PeerValues, PeerValues]:
        """Send (to_m, to_s) in cycle k; return what each side holds for cycle k + 1."""
        if self.cycles == 0 and self.jitter == 0:
            return to_m, to_s
        extra = self.cycles + (int(self.rng.integers(0, self.jitter + 1)) if self.jitter else 0)
        self.last_due = max(self.last_due, k + extra)
        self.queue.append((self.last_due, to_m, to_s))
        while self.queue and self.queue[0][0] <= k:
            _, cur_m, cur_s = self.queue.pop(0)
        return cur_m, cur_s


def _lost(peer: PeerValues) -> PeerValues:
    """The peer as a node sees it once declared lost: its last values, not fresh, not alive."""
    return dataclasses.replace(peer, fresh=False, alive=False)


def _run_render(
    sc,
    rig_m,
    ref,
    params,
    model,
    n_steps,
    period,
    rounding,
    *,
    beta_pad: float = 2.23,
    T_finger0_C: float = 34.0,
    finger_thermometer: bool = True,
    thermometer_lead_s: float = 1.0,
    calibration_presets_C: list[float] | None = None,
    later_model: str = DEFAULT_LATER_MODEL.value,
    table: dict[str, float] | None = None,
) -> SessionResult:
    """Master alone renders each touch's virtual material (settings from the scene's touches).

    ``finger_thermometer``: read the finger's skin temperature ``thermometer_lead_s`` before each
    touch, as yamamoto's radiation thermometer does (else ``T_finger0_C`` for every touch).
    ``calibration_presets_C``: calibration session instead: touch i pre-sets the pad at
    ``calibration_presets_C[i]`` and holds the current during the touch (see session.calibration).
    ``later_model``: the later-phase model (telethermo.control.later_phase: semi_infinite, rc, conduction;
    default conduction). ``table``: material -> β (default: the shipped rendering table; e.g. the operator's
    own, telethermo.offline.finger_betas).
    """
    script = RenderScript(
        sc,
        beta_pad=beta_pad,
        T_finger0_C=T_finger0_C,
        finger_thermometer=finger_thermometer,
        thermometer_lead_s=thermometer_lead_s,
        calibration_presets_C=calibration_presets_C,
        later_model=later_model,
        table=table,
    )
    base = params or default_params(Role.MASTER, period_s=period, mode=Mode.RENDER, render=script.first)
    base = _with_rig_limits(base, rig_m)
    s0 = rig_m.read()
    state = init_state(dataclasses.replace(base, mode=Mode.RENDER, render=script.first), model, s0)
    meta = {
        "scene": getattr(sc, "name", ""),
        "period_s": period,
        "mode": "render",
        "rounding": rounding,
        "contacts": scene_contacts(sc, "master"),
        "finger_thermometer": finger_thermometer,
        "later_model": later_model,
        "master_params": _params_meta(base),
    }

    def params_at(smp) -> CoreParams:
        rs = script.settings_at(smp.t_s, period, lambda: finger_skin_C(rig_m, rig_m.truth()))
        return dataclasses.replace(base, mode=Mode.RENDER, render=rs)

    rec = _lone_master(
        RecordingBuilder(meta), rig_m, ref, state, n_steps, period, params_at, None, with_ref=True
    )
    rec.meta["render"] = script.meta()
    return SessionResult(rec, compute_figures(rec))


def _run_hold(
    sc, rig_m, ref, params, model, n_steps, period, rounding, *, hold_C: float | None = None, **_ignored: Any
) -> SessionResult:
    """A virtual scene that renders nothing (e.g. finger_on_display): the master alone regulates its pad
    at ``hold_C`` (default: the envelope's neutral 32 °C) with the telepresence law against a constant
    virtual peer (estimate hold_C, no flux), whatever touches it."""
    base = params or default_params(Role.MASTER, period_s=period, **HOLD_GAINS)
    base = _with_rig_limits(dataclasses.replace(base, mode=Mode.TELEPRESENCE), rig_m)
    T_hold = float(base.safety.neutral_C if hold_C is None else hold_C)
    peer = PeerValues(T_hold, 0.0)
    s0 = rig_m.read()
    state = init_state(base, model, s0)
    meta = {
        "scene": getattr(sc, "name", ""),
        "period_s": period,
        "mode": "hold",
        "rounding": rounding,
        "hold_C": T_hold,
        "master_params": _params_meta(base),
        "contacts": [{"t_on_s": t.start_s, "t_off_s": t.end_s, "object": t.body} for t in sc.master_contacts],
    }
    rec = _lone_master(
        RecordingBuilder(meta), rig_m, ref, state, n_steps, period, lambda _smp: base, peer, with_ref=False
    )
    return SessionResult(rec, compute_figures(rec))


def _lone_master(
    b: RecordingBuilder,
    rig_m,
    ref,
    state,
    n_steps: int,
    period: float,
    params_at: Callable[[Any], CoreParams],
    peer: PeerValues | None,
    *,
    with_ref: bool,
) -> Recording:
    """The master alone for ``n_steps`` periods (render or hold): each sample's parameters from
    ``params_at(sample)``, a fixed (or no) peer; the reference rig advances alongside (its row with
    ``with_ref``)."""
    for _k in range(n_steps):
        smp = rig_m.read()
        r = step(smp, peer, params_at(smp), state)
        row = {"t_s": smp.t_s}
        row.update(side_row("m", smp, r, peer))
        row.update(truth_row("m", rig_m))
        if with_ref:
            row.update(ref_row(ref))
        b.add(row)
        state = r.state
        rig_m.apply_current(r.current_A)
        rig_m.advance(period)
        ref.advance(period)
    return b.build()


def _with_rig_limits(p: CoreParams, rig) -> CoreParams:
    """The envelope's current limit follows the rig's hardware limit (0.8·I_max of *this* rig), and its
    detached-sensor check the rig's TEM when the rig says it (telethermo.control.detach.tem_limits)."""
    if abs(p.safety.I_max_A - rig.I_max_A) > 1e-12:
        p = dataclasses.replace(p, safety=dataclasses.replace(p.safety, I_max_A=float(rig.I_max_A)))
    tem = tem_limits(rig)
    if any(getattr(p.safety, k) != v for k, v in tem.items()):
        p = dataclasses.replace(p, safety=dataclasses.replace(p.safety, **tem))
    return p


def _finite_or_none(x: Any) -> Any:
    """JSON has no infinity: an unbounded limit (``math.inf``, e.g. an unknown cooling limit) is null."""
    return None if isinstance(x, float) and not math.isfinite(x) else x


def _params_meta(p: CoreParams) -> dict[str, Any]:
    d = {}
    for f in dataclasses.fields(p):
        v = getattr(p, f.name)
        if f.name in ("safety", "contact", "render"):
            d[f.name] = dataclasses.asdict(v) if v is not None else None
            if d[f.name]:
                d[f.name] = {
                    k: (x.value if hasattr(x, "value") else _finite_or_none(x)) for k, x in d[f.name].items()
                }
        else:
            d[f.name] = v.value if hasattr(v, "value") else v
    return d


def write_session(out_dir: str | os.PathLike, result: SessionResult, *, png: bool = True) -> dict[str, Path]:
    """Write ``recording.csv``, ``summary.json`` and ``session.png`` into ``out_dir`` (atomically)."""
    out = Path(out_dir)
    paths = {
        "csv": write_recording_csv(out / "recording.csv", result.recording),
        "json": write_json_atomic(out / "summary.json", result.figures),
    }
    if png:
        paths["png"] = write_session_png(out / "session.png", result.recording)
    return paths
