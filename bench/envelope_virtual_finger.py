"""An experiment for issue 22, not a shipped controller: the envelope matrix with a virtual finger on the
probe.

``python -m bench.envelope_virtual_finger [--b W·s^½/(m²·K)] [--kp A/°C] [--ramp °C/s] [--gate °C]
[--vf-flux KP,KI] [--workers N] [--only I,J] [--out NAME]`` writes ``bench/results/NAME.json`` (default
``envelope_virtual_finger``).

docs/control.md traces most of the matrix's losses to the best constant pad to the probe following the finger
estimate of a display held back by its current and ramp limits: on a cold object the probe gives the object
4–5× a finger's heat, on a hot thin plate (condition 85) it drains it at −3.3 A, 6× the finger's flux. The
candidate: in contact, the probe's setpoint is a virtual finger (:mod:`telethermo.control.virtual_finger`,
``CoreParams.virtual_finger_b``) started at the master's finger estimate and losing the heat the probe's own
sensor measures, with no flux feed-forward; its kp (``--kp`` at the shipped module, scaled like the shipped kp
by the gain rule's ratio) and a probe ramp limit of ``--ramp`` °C/s (the probe has no skin; at 5 °C/s its
setpoint cannot follow the virtual finger's first second). Same conditions as bench/results/envelope.json
(parameters read from it), identified gains, scored against the shipped run's figures in that file (the best
pads do not depend on the controller), plus the base scene (issue 22 keeps its headline <= 1.255 °C).

``--gate G``: the virtual finger only once the probe's estimate leaves the master's skin clamps shrunk by G °C
(latched per touch; the shipped exchange before). ``--vf-flux KP,KI`` (with ``--gate``): the virtual finger in
admittance form (:func:`telethermo.control.virtual_finger.vf_step_held`): its surface held at the probe's
estimate of the object's surface, the heat it draws is the probe's flux target, tracked by a flux PI.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from bench.common import write_results
from bench.envelope_candidate import add_matrix_args, condition_row, load_shipped, only
from bench.envelope_probe_flux import summary
from telethermo.control import core_stages
from telethermo.control.coreparams import NO_GAINS
from telethermo.control.defaults import GAINS
from telethermo.control.pi import FluxPIGains
from telethermo.control.safety_limits import DEFAULT_T_MAX_C, DEFAULT_T_MIN_C
from telethermo.control.types import Role
from telethermo.control.virtual_finger import VirtualFinger, vf_start, vf_step_held
from telethermo.offline import envelope

SHIPPED_SLAVE_KP = GAINS[Role.SLAVE]["kp_A_per_C"]  # 0.43 A/°C
_identified = envelope.identified_params
BASE_KEYS = ("headline_C", "early_C", "late_C", "pre_contact_C")
_CANDIDATE: dict[str, float] = {
    "b": 1100.0,
    "kp": 1.0,
    "ramp": 50.0,
    "master_flux": 1.0,
    "air_kiQ_x": 1.0,
    "gate_C": math.nan,
    "flux_kp": math.nan,
    "flux_ki": math.nan,
}
_request = core_stages._telepresence_request
_envelope = core_stages.envelope
_GATE: dict[str, Any] = {"latched": False, "params": None, "shipped": None, "fast": None}


def _slave_params(role, *args, **kwargs):
    p, fit = _identified(role, *args, **kwargs)
    if role is Role.SLAVE and math.isfinite(_CANDIDATE["gate_C"]):  # shipped gains; the ramp: _gated_envelope
        p = dataclasses.replace(p, virtual_finger_b=_CANDIDATE["b"])
    elif role is Role.SLAVE:
        s = p.kp_A_per_C / SHIPPED_SLAVE_KP  # the gain rule's ratio for this module (1 on the shipped one)
        ramp = _CANDIDATE["ramp"]
        p = dataclasses.replace(
            p,
            virtual_finger_b=_CANDIDATE["b"],
            kp_A_per_C=_CANDIDATE["kp"] * s,
            safety=dataclasses.replace(p.safety, ramp_up_C_per_s=ramp, ramp_down_C_per_s=ramp),
        )
    elif _CANDIDATE["air_kiQ_x"] != 1.0:
        p = dataclasses.replace(p, air_kiQ_A_per_W_s=p.air_kiQ_A_per_W_s * _CANDIDATE["air_kiQ_x"])
    return p, fit


def _master_request(sample, peer, params, state, e, usable):
    """``master_flux`` 0: in contact the display tracks the probe's temperature alone (no flux mirror)."""
    r = _request(sample, peer, params, state, e, usable)
    if not _CANDIDATE["master_flux"] and params.role is Role.MASTER and usable and r.source[1] == "contact":
        r = dataclasses.replace(r, ff=0.0, eQ=0.0, fg=None)
    if r.source[1] == "virtual_finger" and math.isfinite(_CANDIDATE["gate_C"]):
        return _gated(sample, peer, params, state, e, usable, r)
    return r


def _gate_params(params) -> None:
    """Keep the slave's parameters as the session runs them and their shipped and fast-ramp variants (built
    once per session)."""
    if _GATE["params"] is not params:
        ramp = _CANDIDATE["ramp"]
        _GATE.update(
            params=params,
            shipped=dataclasses.replace(params, virtual_finger_b=0.0),
            fast=dataclasses.replace(
                params,
                safety=dataclasses.replace(params.safety, ramp_up_C_per_s=ramp, ramp_down_C_per_s=ramp),
            ),
        )


def _gated(sample, peer, params, state, e, usable, r):
    """``gate_C``: the virtual finger only once the probe's own estimate has left the master's skin clamps
    shrunk by gate_C (latched until the touch ends: there the display saturates and cannot convey what the
    probe does); before, the shipped exchange (its gains object kept, so the oscillation guard acts)."""
    _gate_params(params)
    if e.cst.since_s <= 1.5 * params.period_s:  # a new touch
        _GATE["latched"] = False
    lo, hi = DEFAULT_T_MIN_C + _CANDIDATE["gate_C"], DEFAULT_T_MAX_C - _CANDIDATE["gate_C"]
    _GATE["latched"] = _GATE["latched"] or not lo <= e.est <= hi
    if _GATE["latched"] and math.isfinite(_CANDIDATE["flux_kp"]):
        return _admittance(sample, peer, params, state, e, r)
    if _GATE["latched"]:
        return r
    r0 = _request(sample, peer, _GATE["shipped"], state, e, usable)
    return dataclasses.replace(r0, later_st=r.later_st, gains=params.gains)


def _admittance(sample, peer, params, state, e, r):
    """``flux_kp``: the virtual finger in admittance form: its surface held at the probe's own estimate of the
    object's surface, the heat it draws is the probe's flux target (a flux PI, kp and ki scaled like the
    shipped kp by the gain rule's ratio; no temperature loop)."""
    vf = params.virtual_finger
    prev = state.render_later
    same = prev is not None and isinstance(prev[0], VirtualFinger) and prev[0].b == vf.b
    x = prev[1] if same else vf_start(vf, peer.estimate_C)
    x, q_in = vf_step_held(vf, x, e.est)
    s = _GATE["shipped"].kp_A_per_C / SHIPPED_SLAVE_KP
    fg = FluxPIGains(_CANDIDATE["flux_kp"] * s, _CANDIDATE["flux_ki"] * s)
    return dataclasses.replace(
        r, req=e.est, ff=0.0, eQ=-q_in - sample.Q_W, gains=NO_GAINS, fg=fg, later_st=(vf, x)
    )


def _gated_envelope(params, state, sample, e, T_pred, peer_state, r, fallback):
    """The probe's ramp is ``ramp`` while the gated virtual finger acts, the shipped one otherwise."""
    if r.source[1] == "virtual_finger" and math.isfinite(_CANDIDATE["gate_C"]):
        _gate_params(params)
        params = _GATE["fast"]
    return _envelope(params, state, sample, e, T_pred, peer_state, r, fallback)


def _run(job: tuple[dict[str, Any], dict[str, float]]) -> dict[str, Any]:
    cond, candidate = job
    _CANDIDATE.update({"gate_C": math.nan, **candidate})
    envelope.identified_params = _slave_params
    core_stages._telepresence_request = _master_request
    core_stages.envelope = _gated_envelope
    return condition_row(cond)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m bench.envelope_virtual_finger", description=__doc__.split("\n\n")[0]
    )
    ap.add_argument("--b", type=float, default=1100.0, help="the virtual finger's effusivity, W·s^½/(m²·K)")
    ap.add_argument("--kp", type=float, default=1.0, help="the probe's kp at the shipped module, A/°C")
    ap.add_argument("--ramp", type=float, default=50.0, help="the probe's setpoint ramp limit, °C/s")
    ap.add_argument(
        "--no-master-flux", action="store_true", help="in contact the display tracks temperature alone"
    )
    ap.add_argument("--air-kiQ-x", type=float, default=1.0, help="the display's air flux ki, × identified")
    ap.add_argument(
        "--gate",
        type=float,
        help="the virtual finger only beyond the master's skin clamps shrunk by this, °C (shipped probe "
        "gains before)",
    )
    ap.add_argument(
        "--vf-flux",
        help="KP,KI: with --gate, the virtual finger in admittance form (flux PI gains at the shipped module,"
        " A/W and A/(W·s))",
    )
    ap.add_argument("--out", default="envelope_virtual_finger", help="results name (bench/results/NAME.json)")
    add_matrix_args(ap)
    a = ap.parse_args(argv)
    shipped_run, shipped = load_shipped(a.shipped)
    if a.only:
        shipped = only(shipped, {int(i) for i in a.only.split(",")})
    candidate = {
        "b": a.b,
        "kp": a.kp,
        "ramp": a.ramp,
        "master_flux": 0.0 if a.no_master_flux else 1.0,
        "air_kiQ_x": a.air_kiQ_x,
    }
    if a.gate is not None:
        candidate["gate_C"] = a.gate
    if a.vf_flux:
        candidate["flux_kp"], candidate["flux_ki"] = (float(v) for v in a.vf_flux.split(","))
    jobs = [(c["condition"], candidate) for c in shipped]
    jobs.append((dataclasses.asdict(envelope.base_condition()), candidate))
    with ProcessPoolExecutor(max_workers=a.workers) as ex:
        rows = list(ex.map(_run, jobs))
    base = next(r for r in rows if r["index"] == -1)
    rows = [r for r in rows if r["index"] != -1]
    data = {
        "candidate": candidate,
        **summary(shipped, rows),
        "base": base,
        "shipped_base": {k: shipped_run["base"][k] for k in BASE_KEYS},
        "conditions": rows,
    }
    path = write_results(a.out, data)
    print(json.dumps({k: v for k, v in data.items() if k != "conditions"}, indent=1))
    print(f"written {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
