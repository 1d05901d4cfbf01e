"""The operating envelope (DESIGN.md §10, issue 22): conditions drawn across it, and one condition's session
scored against its own direct touch and the best constant pad.

A :class:`Condition` varies, each side independently where the envelope says so: the room, the objects'
initial
temperature, their materials (three of the table, EPS to copper) and thickness, the probe's and the finger's
contact force, the finger's layers and perfusion, the sensor noise, each rig's TEM (Seebeck, resistance,
conductance, I_max, plate capacity) and heat sink, and the extra one-way transport delay of the exchanged
values
(with jitter). :func:`draw_conditions` gives a seeded Latin hypercube over those ranges plus the corners of
the
four that matter most (object temperature, room, both TEMs' Seebeck, delay). :func:`run_condition` runs the
guiatni §5.3 schedule (three materials, twice each) with the project's controller and scores it:

- headline, pre-contact, early and late errors against the direct touch (telethermo.offline.transparency);
- the best constant pad: a display that ignores the probe and holds the ambient, the objects' temperature or
  the neutral 32 °C (each clamped to the skin's [15, 43] °C), the best of the three;
- the oscillation figure (telethermo.offline.oscillation; per touch in ``oscillation_touches``), trips and
  cut time per side, the skin's extremes and how far past its clamps it went, the cue order and
  whether the direct touch's cues differ enough (≥ 20 %) for the order to be a fair question;
- where the direct touch's skin passes a clamp, how far short of it the display's skin stays, beside a pad
  held at that clamp (:func:`clamp_figures`).

Pure of I/O: the benchmark (bench/envelope_bench.py) submits conditions to an executor and writes the results.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.stats import qmc

from telethermo import sim
from telethermo.control.core import init_state, step
from telethermo.control.defaults import HOLD_GAINS
from telethermo.control.gain_rule import fit_gains, fitted_params
from telethermo.control.params import default_params
from telethermo.control.types import PeerValues, Role
from telethermo.offline.figures import contacts_of
from telethermo.offline.runner import run_offline_session
from telethermo.offline.transparency import transparency_figures
from telethermo.ident import UnstableModelError
from telethermo.ident.experiment import identify_rig

BASE_SCENE = "probe_touches_al_steel_wood"
#: the table's materials a probe may touch, EPS to copper
MATERIALS = (
    "eps",
    "oak",
    "pvc",
    "glass",
    "ceramic",
    "alumina",
    "stainless_steel",
    "carbon_steel",
    "brass",
    "aluminium",
    "copper",
)
#: name -> (low, high, log-scale): the envelope's ranges (issue 22)
RANGES: dict[str, tuple[float, float, bool]] = {
    "ambient_C": (15.0, 32.0, False),
    "object_T_C": (5.0, 50.0, False),
    "thickness_mm": (0.3, 20.0, True),
    "probe_force_N": (0.5, 20.0, True),
    "finger_force_N": (0.5, 20.0, True),
    "finger_layers_x": (0.7, 1.3, False),
    "perfusion_x": (0.7, 1.3, False),
    "noise_x": (1.0, 3.0, False),
    "m_seebeck_x": (0.5, 2.5, False),
    "m_R_x": (0.5, 4.0, True),
    "m_K_x": (0.5, 2.0, True),
    "m_I_max_A": (1.5, 6.0, False),
    "m_plate_C_x": (0.5, 2.0, True),
    "m_sink_R_K_W": (0.3, 1.2, False),
    "s_seebeck_x": (0.5, 2.5, False),
    "s_R_x": (0.5, 4.0, True),
    "s_K_x": (0.5, 2.0, True),
    "s_I_max_A": (1.5, 6.0, False),
    "s_plate_C_x": (0.5, 2.0, True),
    "s_sink_R_K_W": (0.3, 1.2, False),
    "delay_ms": (0.0, 100.0, False),
}
CORNER_KEYS = ("object_T_C", "ambient_C", "seebeck_x", "delay_ms")
SKIN_CLAMP_C = (15.0, 43.0)
NEUTRAL_C = 32.0
CUE_DIFFERENCE_MIN = 0.20
SESSION_LONG_CUT_S = 5.0
#: the skin within this much of a clamp the direct touch passes has reached it (issue 22, item 4), °C
CLAMP_REACH_C = 0.5


@dataclass(frozen=True)
class Condition:
    """One point of the envelope (units in the names; ``*_x`` are factors on the shipped rig's value)."""

    index: int
    design: str  # "lhs" or "corner" or "base"
    materials: tuple[str, str, str]
    ambient_C: float = 25.0
    object_T_C: float = 25.0
    thickness_mm: float = 20.0
    probe_force_N: float = 8.0
    finger_force_N: float = 8.0
    finger_layers_x: float = 1.0
    perfusion_x: float = 1.0
    noise_x: float = 1.0
    m_seebeck_x: float = 1.0
    m_R_x: float = 1.0
    m_K_x: float = 1.0
    m_I_max_A: float = 3.0
    m_plate_C_x: float = 1.0
    m_sink_R_K_W: float = 0.6
    s_seebeck_x: float = 1.0
    s_R_x: float = 1.0
    s_K_x: float = 1.0
    s_I_max_A: float = 3.0
    s_plate_C_x: float = 1.0
    s_sink_R_K_W: float = 0.6
    delay_ms: float = 0.0
    seed: int = 0

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Condition:
        """The condition of a results row (``dataclasses.asdict`` through JSON: its tuples came back as
        lists)."""
        return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in d.items()})


def base_condition() -> Condition:
    """guiatni §5.3 as shipped: aluminium, steel, oak at the 25 °C room, 8 N, the shipped TEM on both
    sides."""
    return Condition(index=-1, design="base", materials=("aluminium", "carbon_steel", "oak"))


def draw_conditions(n: int, seed: int, *, corners: bool = True) -> list[Condition]:
    """``n`` Latin-hypercube conditions (seeded) plus, with ``corners``, the 16 corners of
    :data:`CORNER_KEYS` (other parameters at the shipped values). Materials: three distinct, drawn per
    condition from :data:`MATERIALS`."""
    keys = list(RANGES)
    u = qmc.LatinHypercube(d=len(keys), seed=seed).random(n)
    rng = np.random.default_rng(seed + 1)
    out = []
    for i in range(n):
        kw: dict[str, Any] = {}
        for j, k in enumerate(keys):
            lo, hi, log = RANGES[k]
            kw[k] = float(
                math.exp(math.log(lo) + u[i, j] * (math.log(hi) - math.log(lo)))
                if log
                else lo + u[i, j] * (hi - lo)
            )
        mats = tuple(str(m) for m in rng.choice(MATERIALS, size=3, replace=False))
        cond = Condition(
            index=i,
            design="lhs",
            materials=mats,  # type: ignore[arg-type]
            seed=seed * 100003 + i,
            **kw,
        )
        out.append(cond)
    if corners:
        for c in range(16):
            bits = [(c >> b) & 1 for b in range(4)]
            kw = {
                "object_T_C": (5.0, 50.0)[bits[0]],
                "ambient_C": (15.0, 32.0)[bits[1]],
                "m_seebeck_x": (0.5, 2.5)[bits[2]],
                "s_seebeck_x": (0.5, 2.5)[bits[2]],
                "delay_ms": (0.0, 100.0)[bits[3]],
            }
            out.append(
                Condition(
                    index=n + c,
                    design="corner",
                    materials=("aluminium", "carbon_steel", "oak"),
                    seed=seed * 100003 + n + c,
                    **kw,
                )
            )  # type: ignore[arg-type]
    return out


def _rig(base: Any, side: str, c: Condition) -> Any:
    g = lambda name: getattr(c, f"{side}_{name}")  # noqa: E731
    tem = dataclasses.replace(
        base.tem,
        alpha_V_K=base.tem.alpha_V_K * g("seebeck_x"),
        R_ohm=base.tem.R_ohm * g("R_x"),
        K_W_K=base.tem.K_W_K * g("K_x"),
        I_max_A=g("I_max_A"),
        plate_C_J_K=base.tem.plate_C_J_K * g("plate_C_x"),
    )
    return base.with_(tem=tem, sink_R_K_W=g("sink_R_K_W"))


def condition_scene(c: Condition) -> tuple[Any, Any]:
    """The §5.3 scene under condition ``c``: (scene with the master's rig, the slave's rig parameters)."""
    sc = sim.load_scene(BASE_SCENE)
    names = ("a", "b", "c")
    objects = {
        n: dataclasses.replace(
            sc.objects["aluminium"], name=n, material=m, thickness_m=c.thickness_mm * 1e-3, T0_C=c.object_T_C
        )
        for n, m in zip(names, c.materials)
    }
    slave = tuple(
        dataclasses.replace(t, body=names[i % 3], force_N=c.probe_force_N)
        for i, t in enumerate(sc.slave_contacts)
    )
    master = tuple(dataclasses.replace(t, force_N=c.finger_force_N) for t in sc.master_contacts)
    f = sc.finger
    finger = dataclasses.replace(
        f, layers=tuple((m, t * c.finger_layers_x, w * c.perfusion_x) for m, t, w in f.layers)
    )
    noise = dataclasses.replace(
        sc.noise, T_sigma_C=sc.noise.T_sigma_C * c.noise_x, Q_sigma_W=sc.noise.Q_sigma_W * c.noise_x
    )
    base = sc.rig_params
    scene = dataclasses.replace(
        sc,
        name=f"envelope_{c.index}",
        ambient_C=c.ambient_C,
        objects=objects,
        slave_contacts=slave,
        master_contacts=master,
        finger=finger,
        noise=noise,
        seed=c.seed,
        rig_params=_rig(base, "m", c),
    )
    return scene, _rig(base, "s", c)


def hold_skin(sc: Any, T_hold_C: float) -> np.ndarray:
    """The finger's skin on a display that ignores the probe and holds its pad at ``T_hold_C`` (°C, per
    step). The holder knows its module: its cooling current stops at the module's true maximum-cooling
    current at the skin's low clamp (``TEMParams.peak_cooling_current_A``), as the telepresence node's does
    at its identified one; without that a weak module's pad runs away hot (the matrix's condition 88: skin
    44.8 °C while held at 15 °C)."""
    rig = sim.build_rig(sc, "master")
    dt = rig.period_s
    n = int(round(sc.duration_s / dt))
    p = dataclasses.replace(default_params(Role.MASTER, period_s=dt, **HOLD_GAINS), air_rendering=False)
    cool = sc.rig_params.tem.peak_cooling_current_A(SKIN_CLAMP_C[0])
    safety = dataclasses.replace(p.safety, I_max_A=rig.I_max_A, cooling_limit_A=cool)
    p = dataclasses.replace(p, safety=safety)
    st = init_state(p, None, rig.read())
    skin = np.empty(n)
    for k in range(n):
        s = rig.read()
        skin[k] = rig.truth().T_surface_C
        r = step(s, PeerValues(T_hold_C, 0.0), p, st)
        st = r.state
        rig.apply_current(r.current_A)
        rig.advance(dt)
    return skin


def identified_params(
    role: Role, rig_params: Any, ambient_C: float, period_s: float, seed: int
) -> tuple[Any, dict[str, Any]]:
    """What a lab does after swapping a module: ``telethermo identify`` on the free pad of this rig (the
    default 10 000-sample PRBS; when the fit is refused as unstable, again with another seed and then with
    20 000 samples, as its message advises), then the role's gains from the identified model
    (telethermo.control.gain_rule). Returns (CoreParams, the rule's fit; ``identify_attempts`` says how many
    runs it took, and a fit of None means every attempt was refused: the shipped gains run)."""
    attempts = 0
    for n_samples, s in ((10_000, seed), (10_000, seed + 1000), (20_000, seed + 2000)):
        attempts += 1
        rig = sim.free_pad_rig(period_s=period_s, ambient_C=ambient_C, seed=s, params=rig_params)
        try:
            model, _ = identify_rig(rig, seed=s, n_samples=n_samples)
        except UnstableModelError:
            continue
        fit = fit_gains(model, role)
        fit["identify_attempts"] = attempts
        return fitted_params(default_params(role, period_s=period_s), fit), fit
    return default_params(role, period_s=period_s), {
        "rho": 1.0,
        "margins": {},
        "identify_attempts": attempts,
        "identify_refused": True,
    }


def condition_session(
    c: Condition, gains: str = "identified", rig_path: Any = None
) -> tuple[Any, Any, dict[str, Any]]:
    """The session of condition ``c`` as :func:`run_condition` runs it, unscored: (scene, the offline
    session's result, the gain rule's fits per side; empty with ``gains="shipped"``). ``rig_path``: passed
    to :func:`~telethermo.offline.runner.run_offline_session` (what each controller drives)."""
    sc, rig_s = condition_scene(c)
    delay = int(round(c.delay_ms / (1000.0 * sc.period_s)))
    pm = ps = None
    fits: dict[str, Any] = {}
    if gains == "identified":
        pm, fits["master"] = identified_params(
            Role.MASTER, sc.rig_params, c.ambient_C, sc.period_s, c.seed % 9973
        )
        ps, fits["slave"] = identified_params(Role.SLAVE, rig_s, c.ambient_C, sc.period_s, c.seed % 9973 + 1)
    res = run_offline_session(
        sc,
        master_params=pm,
        slave_params=ps,
        slave_rig_params=rig_s,
        delay_cycles=delay,
        delay_jitter_cycles=2 if delay else 0,
        seed=c.seed % 100000,
        rig_path=rig_path,
    )
    return sc, res, fits


def run_condition(
    c: Condition, *, with_pads: bool = True, gains: str = "identified", with_shipped: bool = False
) -> dict[str, Any]:
    """Run condition ``c`` and score it (see the module docstring). JSON-safe. ``gains``: "identified" (each
    side identifies its rig and derives its gains) or "shipped" (the shipped gains whatever the rig);
    ``with_shipped``: also the shipped gains' headline and oscillation, as the before-figure of the same
    draw."""
    sc, res, fits = condition_session(c, gains)
    rec, fig = res.recording, res.figures
    t, ref = rec.col("t_s"), rec.col("ref_T_contact_C")
    contacts = contacts_of(rec)
    tf = transparency_figures(
        t,
        rec.col("m_true_surface_C"),
        ref,
        rec.col("m_true_Q_into_body_W"),
        rec.col("ref_Q_into_finger_W"),
        contacts,
    )
    out: dict[str, Any] = {
        "condition": dataclasses.asdict(c),
        "gains": gains,
        "gain_fit": {k: _fit_summary(v) for k, v in fits.items()},
        "headline_C": tf["headline_error_C"],
        "pre_contact_C": tf["pre_contact_mean_error_C"],
        "early_C": tf["early_mean_error_C"],
        "late_C": tf["late_mean_error_C"],
    }
    cue = tf["cue"]
    direct = sorted(v["direct_J"] for v in cue["materials"].values())
    rel = [abs(b - a) / max(abs(b), 1e-9) for a, b in zip(direct, direct[1:])]
    out["cue_order_kept"] = bool(cue["order_kept"])
    out["cue_fair"] = bool(rel) and min(rel) >= CUE_DIFFERENCE_MIN
    osc = fig["oscillation"]
    out["oscillation_ratio"] = osc["worst_ratio"]
    out["oscillating"] = bool(osc["oscillating"])
    out["skin_band_rms_max_C"] = osc["skin_band_rms_max_C"]
    out["current_band_rms_max_A"] = osc["current_band_rms_max_A"]
    out["oscillation_touches"] = [
        {k: t[k] for k in ("object", "t_on_s", "ratio", "current_band_rms_A", "oscillating")}
        for t in osc["per_touch"]
    ]
    sfy = fig["safety"]
    out["trips"] = [{"side": x["side"], "trip": x["trip"], "t_s": x["t_s"]} for x in sfy["trips"]]
    out["time_cut_s"] = sfy["time_cut_s"]
    out["session_long_cut"] = any(v >= SESSION_LONG_CUT_S for v in sfy["time_cut_s"].values())
    out["time_at_limit_s"] = sfy["time_at_limit_s"]
    out.update(skin_extremes(rec.col("m_true_surface_C")))
    out.update(clamp_figures(sc, rec.col("m_true_surface_C"), ref))
    if with_shipped and gains != "shipped":
        out["shipped"] = _shipped(c)
    if with_pads:
        out.update(_best_pad(c, sc, t, ref, rec.col("ref_Q_into_finger_W"), contacts, out["headline_C"]))
    return out


def skin_extremes(skin_C: np.ndarray) -> dict[str, float]:
    """The operator's skin over the session (``m_true_surface_C``): its highest and lowest temperature, °C,
    and how far it went past the skin's clamps :data:`SKIN_CLAMP_C` (0 inside them), °C.

    >>> skin_extremes(np.array([30.0, 43.2, np.nan, 14.9]))["skin_past_clamp_C"]  # the worse side
    0.2
    >>> skin_extremes(np.array([14.7, 42.9]))["skin_past_clamp_C"], skin_extremes(np.array([15.0, 43.0]))
    (0.3, {'skin_max_C': 43.0, 'skin_min_C': 15.0, 'skin_past_clamp_C': 0.0})
    """
    s = skin_C[np.isfinite(skin_C)]
    if not s.size:
        return {"skin_max_C": math.nan, "skin_min_C": math.nan, "skin_past_clamp_C": math.nan}
    hi, lo = float(s.max()), float(s.min())
    past = max(hi - SKIN_CLAMP_C[1], SKIN_CLAMP_C[0] - lo, 0.0)
    return {"skin_max_C": hi, "skin_min_C": lo, "skin_past_clamp_C": round(past, 6)}


def clamp_short(skin_C: np.ndarray, direct_C: np.ndarray) -> float | None:
    """Where the direct touch's skin ``direct_C`` goes past a skin clamp (:data:`SKIN_CLAMP_C`), how far short
    of that clamp the display's skin ``skin_C`` stays at its closest, °C (0 if it reaches or passes it; the
    worse clamp when both are passed); None when the direct touch stays inside both.

    >>> clamp_short(np.array([30.0, 16.2]), np.array([33.0, 12.0]))
    1.2
    >>> clamp_short(np.array([16.0]), np.array([16.0])) is None  # the direct touch stays inside the clamps
    True
    >>> clamp_short(np.array([14.9, 42.0]), np.array([12.0, 44.0]))  # the low clamp reached, the high one not
    1.0
    """
    d, s = direct_C[np.isfinite(direct_C)], skin_C[np.isfinite(skin_C)]
    if not d.size or not s.size:
        return None
    lo, hi = SKIN_CLAMP_C
    short = ([round(max(float(s.min()) - lo, 0.0), 6)] if d.min() < lo else []) + (
        [round(max(hi - float(s.max()), 0.0), 6)] if d.max() > hi else []
    )
    return max(short) if short else None


def clamp_figures(sc: Any, skin_C: np.ndarray, direct_C: np.ndarray) -> dict[str, Any]:
    """:func:`clamp_short` of the display's skin, and its baseline in the same run: a pad held at the clamp
    the direct touch passes (the low one if both) for the whole session by the node's own envelope (what
    keeps its skin off the clamp: the guard and taper, about 0.9 °C at any force, and at low finger force the
    contact resistance as well: 3.96 °C at 0.54 N in the matrix's condition 23)."""
    short = clamp_short(skin_C, direct_C)
    if short is None:
        return {"clamp_short_C": None, "clamp_short_pad_C": None}
    lo, hi = SKIN_CLAMP_C
    T = lo if np.nanmin(direct_C) < lo else hi
    return {"clamp_short_C": short, "clamp_short_pad_C": clamp_short(hold_skin(sc, T), direct_C)}


def _fit_summary(v: dict[str, Any]) -> dict[str, Any]:
    return {
        "rho": v["rho"],
        "identify_attempts": v["identify_attempts"],
        "identify_refused": v.get("identify_refused", False),
        "max_cooling_A": v.get("max_cooling_A"),
        **v["margins"],
    }


SHIPPED_KEYS = (
    "headline_C",
    "pre_contact_C",
    "early_C",
    "late_C",
    "oscillation_ratio",
    "oscillating",
    "current_band_rms_max_A",
    "cue_order_kept",
)


def _shipped(c: Condition) -> dict[str, Any]:
    """The shipped gains on the same draw: the before-figure."""
    sh = run_condition(c, with_pads=False, gains="shipped")
    return {
        **{k: sh[k] for k in SHIPPED_KEYS},
        "trips": len(sh["trips"]),
        "session_long_cut": sh["session_long_cut"],
    }


def _best_pad(
    c: Condition,
    sc: Any,
    t: np.ndarray,
    ref: np.ndarray,
    q_ref: np.ndarray,
    contacts: list[dict[str, Any]],
    headline_C: float,
) -> dict[str, Any]:
    """The three constant pads (room, objects, neutral; clamped to the skin's range) and the best of them."""
    pads = {}
    for name, T in (("ambient", c.ambient_C), ("objects", c.object_T_C), ("neutral", NEUTRAL_C)):
        T = min(max(T, SKIN_CLAMP_C[0]), SKIN_CLAMP_C[1])
        f = transparency_figures(t, hold_skin(sc, T), ref, np.zeros_like(t), q_ref, contacts)
        pads[name] = {"hold_C": T, "headline_C": f["headline_error_C"]}
    best = min(pads, key=lambda k: pads[k]["headline_C"])
    return {
        "pads": pads,
        "best_pad": best,
        "best_pad_headline_C": pads[best]["headline_C"],
        "beats_best_pad": bool(headline_C < pads[best]["headline_C"]),
    }
