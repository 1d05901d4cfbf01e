"""The figures of a session, each a pure function of a :class:`~telethermo.recording.format.Recording`.

Telepresence (guiatni §5.3; issue 4):

- **transparency**: what the operator's finger feels on the master (``m_true_surface_C``, the skin on
  the pad) against the direct-touch reference (``ref_T_contact_C``, the same finger on the same
  object), per touch of the probe (:mod:`telethermo.offline.transparency`): ``pre`` (0.5 s before),
  ``early`` (0–1 s), ``early01`` (0.1–1 s), ``late`` (1–3 s) and the **headline** ``headline_error_C``
  (mean over [t_on − 0.5 s, t_on + 1 s]: a display that ignores the probe cannot game it), the cue
  (heat drawn from the finger over 0–1 s, J) and the skin change, display vs direct. ``per_contact``
  keeps the earlier per-touch statistics (0.1–1 s, 1–3 s, heat flux through the sensor).
- **discrimination_cue**: the direct-touch order of the materials' cues, kept or not by the display,
  and the contrast ratio of every pair.
- **tracking** (internal): each side's error to its target (``X_target_C - X_feedback_C``), RMS in
  steady contact; each controller against its own estimate, so it says nothing about the truth.
- **discrimination**: per object, the rendered early-phase (0.1–1 s) temperature (mean over
  touches); the order must match the reference's, consecutive margins compared with the finger's
  ~0.7 °C cold-detection threshold.
- **safety**: time at each envelope limit per side, time with the current cut, the trips.

Hold (a virtual scene that renders nothing): the master regulates its pad at ``meta["hold_C"]``;
RMS of the tracking error and of the skin vs the target in steady contact.

Render (yamamoto): per touch of the display, the rendered early-phase contact temperature against
eq. 1's prediction (``meta["render"][i]["T_contact_C"]``).

Without truth columns (a hardware recording) the master's finger estimate ``m_estimate_C`` stands in
for ``m_true_surface_C`` (reported as ``"surface_source": "estimate"``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from telethermo.recording.format import Recording
from telethermo.offline.oscillation import oscillation_figures
from telethermo.offline.transparency import transparency_figures
from telethermo.control.safety import EMCY_CODES, Trip

EARLY_S = (0.1, 1.0)
LATE_S = (1.0, 3.0)
PRE_S = 0.5  # the skin vs the reference finger in air, over the last 0.5 s before each touch
COLD_THRESHOLD_C = 0.7  # the finger's cold-detection threshold (issue 4)


def contacts_of(rec: Recording) -> list[dict[str, Any]]:
    """Touches of the session: ``meta["contacts"]`` if given, else the edges of ``ref_touching``."""
    meta = rec.meta.get("contacts")
    if meta:
        return [
            dict(t_on_s=float(c["t_on_s"]), t_off_s=float(c["t_off_s"]), object=str(c.get("object", "")))
            for c in meta
        ]
    t = rec.col("t_s")
    touch = rec.col("ref_touching")
    if not np.isfinite(touch).any():
        touch = rec.col("s_true_touching") if rec.meta.get("mode") != "render" else rec.col("m_true_touching")
    touch = np.nan_to_num(touch) > 0.5
    out = []
    k = 0
    n = len(t)
    while k < n:
        if touch[k]:
            j = k
            while j + 1 < n and touch[j + 1]:
                j += 1
            out.append(dict(t_on_s=float(t[k]), t_off_s=float(t[j]), object=""))
            k = j + 1
        else:
            k += 1
    return out


def _window(t: np.ndarray, c: dict[str, Any], w: tuple[float, float]) -> np.ndarray:
    """Samples in [t_on + w0, t_on + w1) clipped at the release (inclusive)."""
    t0 = c["t_on_s"] + w[0]
    end = c["t_on_s"] + w[1]
    upper = (t <= c["t_off_s"] + 1e-9) if c["t_off_s"] < end else (t < end - 1e-9)
    return (t >= t0 - 1e-9) & upper


def _err_stats(err: np.ndarray) -> dict[str, float]:
    err = err[np.isfinite(err)]
    if err.size == 0:
        return {"mean_abs": math.nan, "max_abs": math.nan, "n": 0}
    a = np.abs(err)
    return {"mean_abs": float(a.mean()), "max_abs": float(a.max()), "n": int(a.size)}


def _nanmean(x: np.ndarray) -> float:
    x = x[np.isfinite(x)]
    return float(x.mean()) if x.size else math.nan


def _clean(o: Any) -> Any:
    """JSON-safe: NaN/inf -> None."""
    if isinstance(o, float):
        return o if math.isfinite(o) else None
    if isinstance(o, dict):
        return {k: _clean(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_clean(v) for v in o]
    return o


def _safety(rec: Recording) -> dict[str, Any]:
    t = rec.col("t_s")
    dt = float(rec.meta.get("period_s") or (np.median(np.diff(t)) if len(t) > 1 else 0.0))
    out: dict[str, Any] = {"time_at_limit_s": {}, "time_cut_s": {}, "trips": []}
    for side in ("m", "s"):
        name = "master" if side == "m" else "slave"
        counts: dict[str, int] = {}
        for cell in rec.text(f"{side}_limits"):
            for lim in filter(None, cell.split("|")):
                counts[lim] = counts.get(lim, 0) + 1
        out["time_at_limit_s"][name] = {k: v * dt for k, v in sorted(counts.items())}
        st = rec.col(f"{side}_safety_state")
        out["time_cut_s"][name] = float(np.sum(st == 3) * dt)
        for k, cell in enumerate(rec.text(f"{side}_new_trips")):
            for trip in filter(None, cell.split("|")):
                out["trips"].append({"t_s": float(t[k]), "side": name, "trip": trip})
    for tr in out["trips"]:
        try:
            tr["emcy_code"] = f"0x{EMCY_CODES[Trip(tr['trip'])]:04X}"
        except ValueError:
            tr["emcy_code"] = None
    out["n_trips"] = len(out["trips"])
    return out


def _surface(rec: Recording) -> tuple[np.ndarray, str]:
    s = rec.col("m_true_surface_C")
    if np.isfinite(s).any():
        return s, "truth"
    return rec.col("m_estimate_C"), "estimate"


def compute_figures(rec: Recording) -> dict[str, Any]:
    """All figures of a recording as a JSON-safe dict (see module docstring)."""
    mode = rec.meta.get("mode", "telepresence")
    t = rec.col("t_s")
    out: dict[str, Any] = {
        "mode": mode,
        "scene": rec.meta.get("scene"),
        "period_s": rec.meta.get("period_s"),
        "rounding": rec.meta.get("rounding", "none"),
        "n_steps": len(rec),
        "duration_s": float(t[-1] - t[0]) if len(t) > 1 else 0.0,
    }
    surf, src = _surface(rec)
    out["surface_source"] = src
    contacts = contacts_of(rec)
    out["safety"] = _safety(rec)
    if mode == "render":
        out["render"] = _render_figures(rec, t, surf, contacts)
        return _clean(out)
    if mode == "hold":
        out["hold"] = _hold_figures(rec, t, contacts)
        return _clean(out)

    per = _per_contact(rec, t, surf, contacts)
    honest = transparency_figures(
        t,
        surf,
        rec.col("ref_T_contact_C"),
        rec.col("m_true_Q_into_body_W"),
        rec.col("ref_Q_into_finger_W"),
        contacts,
    )

    def agg(key: str, stat: str) -> float:
        vals = [p[key][stat] for p in per if p[key]["n"]]
        if not vals:
            return math.nan
        return float(np.mean(vals)) if stat == "mean_abs" else float(np.max(vals))

    out["transparency"] = {
        # what the operator feels (telethermo.offline.transparency): the headline is the mean |skin − direct
        # skin| over [t_on − 0.5 s, t_on + 1 s]; early = 0–1 s, early01 = 0.1–1 s, late = 1–3 s
        "headline_error_C": honest["headline_error_C"],
        "pre_contact_mean_error_C": honest["pre_contact_mean_error_C"],
        "early_mean_error_C": honest["early_mean_error_C"],
        "early01_mean_error_C": honest["early01_mean_error_C"],
        "late_mean_error_C": honest["late_mean_error_C"],
        "per_touch": honest["per_touch"],
        "early01_max_error_C": agg("early_T", "max_abs"),
        "late_max_error_C": agg("late_T", "max_abs"),
        "early01_mean_flux_error_W": agg("early_Q", "mean_abs"),
        "early01_max_flux_error_W": agg("early_Q", "max_abs"),
        "late_mean_flux_error_W": agg("late_Q", "mean_abs"),
        "late_max_flux_error_W": agg("late_Q", "max_abs"),
        "per_contact": per,
    }
    lim = (rec.meta.get("master_params") or {}).get("safety") or {}
    I_lim = float(lim.get("current_fraction", 0.8)) * float(lim.get("I_max_A", 3.0))
    out["oscillation"] = oscillation_figures(
        t, surf, rec.col("ref_T_contact_C"), rec.col("m_current_A"), contacts, I_lim
    )
    out["discrimination_cue"] = honest["cue"]
    out["tracking"] = _tracking(rec, t, contacts)
    out["discrimination"] = _discrimination(per)
    return _clean(out)


def _per_contact(
    rec: Recording, t: np.ndarray, surf: np.ndarray, contacts: list[dict[str, Any]]
) -> list[dict]:
    """Legacy per-contact errors (°C, W) of the pad surface against the direct-touch reference."""
    ref = rec.col("ref_T_contact_C")
    q_m = rec.col("m_true_Q_W")
    q_ref = rec.col("ref_Q_into_finger_W")
    per = []
    for c in contacts:
        e, l = _window(t, c, EARLY_S), _window(t, c, LATE_S)
        pre = (t >= c["t_on_s"] - PRE_S - 1e-9) & (t < c["t_on_s"] - 1e-9)
        per.append(
            {
                "object": c["object"],
                "t_on_s": c["t_on_s"],
                "t_off_s": c["t_off_s"],
                "early_T": _err_stats(surf[e] - ref[e]),
                "late_T": _err_stats(surf[l] - ref[l]),
                "pre_T": _err_stats(surf[pre] - ref[pre]),
                "early_Q": _err_stats(q_m[e] - q_ref[e]),
                "late_Q": _err_stats(q_m[l] - q_ref[l]),
                "rendered_early_C": _nanmean(surf[e]),
                "reference_early_C": _nanmean(ref[e]),
            }
        )
    return per


def _tracking(rec: Recording, t: np.ndarray, contacts: list[dict[str, Any]]) -> dict[str, Any]:
    """Tracking RMS in steady contact, °C (internal: each controller against its own estimate)."""
    trk: dict[str, Any] = {}
    pooled = []
    steady = np.zeros(len(t), bool)
    for c in contacts:
        steady |= (t >= c["t_on_s"] + LATE_S[0]) & (t <= c["t_off_s"])
    for side, name in (("m", "master"), ("s", "slave")):
        err = rec.col(f"{side}_target_C") - rec.col(f"{side}_feedback_C")
        e = err[steady & np.isfinite(err)]
        trk[f"{name}_rms_C"] = float(np.sqrt(np.mean(e**2))) if e.size else math.nan
        pooled.append(e)
    allerr = np.concatenate(pooled) if pooled else np.array([])
    trk["rms_C"] = float(np.sqrt(np.mean(allerr**2))) if allerr.size else math.nan
    trk["internal"] = "each controller against its own estimate, not against the truth"
    return trk


def _discrimination(per: list[dict]) -> dict[str, Any]:
    """Rendered early temperature per object and whether the direct-touch order is kept, °C."""
    objs: dict[str, dict[str, list[float]]] = {}
    for p in per:
        o = objs.setdefault(p["object"] or "?", {"rendered": [], "reference": []})
        o["rendered"].append(p["rendered_early_C"])
        o["reference"].append(p["reference_early_C"])
    table = {
        k: {
            "rendered_C": _nanmean(np.array(v["rendered"])),
            "reference_C": _nanmean(np.array(v["reference"])),
            "touches": len(v["rendered"]),
        }
        for k, v in objs.items()
    }
    # objects a shortened session never touched have no early temperature and no place in the order
    seen = [k for k, v in table.items() if math.isfinite(v["rendered_C"]) and math.isfinite(v["reference_C"])]
    ref_order = sorted(seen, key=lambda k: table[k]["reference_C"])
    ren_order = sorted(seen, key=lambda k: table[k]["rendered_C"])
    margins = [table[b]["rendered_C"] - table[a]["rendered_C"] for a, b in zip(ref_order, ref_order[1:])]
    ref_margins = [
        table[b]["reference_C"] - table[a]["reference_C"] for a, b in zip(ref_order, ref_order[1:])
    ]
    return {
        "objects": table,
        "reference_order_coldest_first": ref_order,
        "rendered_order_coldest_first": ren_order,
        "order_kept": len(seen) >= 2 and ref_order == ren_order and all(m > 0 for m in margins),
        "n_materials_compared": len(seen),
        "margins_C": margins,
        "reference_margins_C": ref_margins,
        "min_margin_C": float(min(margins)) if margins else math.nan,
        "threshold_C": COLD_THRESHOLD_C,
        "margins_above_threshold": bool(margins) and min(margins) > COLD_THRESHOLD_C,
    }


def _render_figures(
    rec: Recording, t: np.ndarray, surf: np.ndarray, contacts: list[dict[str, Any]]
) -> dict[str, Any]:
    targets = rec.meta.get("render") or []
    finger = rec.col("m_true_finger_C")
    ref = rec.col("ref_T_contact_C")
    per = []
    for i, c in enumerate(contacts):
        e = _window(t, c, EARLY_S)
        tgt = targets[i] if i < len(targets) else {}
        beta = tgt.get("beta")
        T_o = float(tgt.get("T_object0_C", math.nan))
        pre = (t >= c["t_on_s"] - 0.05 - 1e-9) & (t < c["t_on_s"] - 1e-9)
        T_f0 = _nanmean(finger[pre])  # the true skin temperature just before the touch
        T_eq1 = (T_f0 + beta * T_o) / (1.0 + beta) if beta and math.isfinite(T_f0) else math.nan
        T_cmd = float(tgt.get("T_contact_C", math.nan))
        rendered = _nanmean(surf[e])
        st = _err_stats(surf[e] - T_eq1)
        per.append(
            {
                "material": tgt.get("material", c["object"]),
                "beta": beta,
                "t_on_s": c["t_on_s"],
                "T_finger0_true_C": T_f0,
                "T_finger0_used_C": tgt.get("T_finger0_C"),
                "T_contact_eq1_C": T_eq1,
                "T_contact_commanded_C": T_cmd,
                "T_pad0_C": tgt.get("T_pad0_C"),
                "rendered_early_mean_C": rendered,
                "early_mean_error_C": rendered - T_eq1,
                "early_mean_abs_error_C": st["mean_abs"],
                "early_max_abs_error_C": st["max_abs"],
                "reference_early_mean_C": _nanmean(ref[e]),
            }
        )
    errs = [abs(p["early_mean_error_C"]) for p in per if math.isfinite(p["early_mean_error_C"])]
    return {
        "per_touch": per,
        "max_abs_mean_error_C": float(max(errs)) if errs else math.nan,
        "max_mean_abs_error_C": float(max(p["early_mean_abs_error_C"] for p in per)) if per else math.nan,
    }


def _hold_figures(rec: Recording, t: np.ndarray, contacts: list[dict[str, Any]]) -> dict[str, Any]:
    """Regulation of the pad at a constant target (virtual scenes that render nothing): RMS of the
    controller's error and of the true skin vs the target, from 1 s after each touch to its end."""
    T_hold = float(rec.meta.get("hold_C", math.nan))
    err = rec.col("m_target_C") - rec.col("m_feedback_C")
    skin = rec.col("m_true_surface_C") - T_hold
    steady = np.zeros(len(t), bool)
    for c in contacts:
        steady |= (t >= c["t_on_s"] + LATE_S[0]) & (t <= c["t_off_s"])
    e, k = err[steady & np.isfinite(err)], skin[steady & np.isfinite(skin)]
    return {
        "hold_C": T_hold,
        "tracking_rms_C": float(np.sqrt(np.mean(e**2))) if e.size else math.nan,
        "skin_rms_error_C": float(np.sqrt(np.mean(k**2))) if k.size else math.nan,
    }
