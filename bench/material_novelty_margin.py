"""How far beyond its references' range an envelope classifier's input may lie and still be named (issue 23):
the development measurement behind telethermo.control.material_stream.ENVELOPE_NOVELTY_MARGIN.

``python -m bench.material_novelty_margin [--touches N]`` simulates N (300) touches across the envelope (the
envelope classifier's development set, material_envelope_refs.ENV_DEVELOPMENT) and N touches each with one
condition beyond it (material_touches.OUTSIDE_DEVELOPMENT: a 60–90 °C or −15–0 °C object, 40–100 N, a
0.02–0.1 mm foil, noise × 6–10), computes both classifiers' network inputs from the probe's own signals and
prints, per margin (in the references' standard deviations), the share of touches beyond it: inside the
envelope that is the price (answers turned into "unknown"), outside it the detection. Neither set meets the
bench's evaluation seeds. About 2 min here.
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np

from bench import material_id_envelope as me
from telethermo.control import material_id as mi
from telethermo.control import material_trust as ms
from telethermo.control.material_trust import ENVELOPE_T_OBJECT_C
from telethermo.control.material_calib import ENVELOPE_EARLY, ENVELOPE_LATE, inputs, load_calibration
from telethermo.offline import material_touches as mt
from telethermo.offline.material_envelope_calibration import EARLY, LATE, vectors
from telethermo.offline.material_envelope_refs import ENV_DEVELOPMENT
from telethermo.sim.tem import load_rig_params

MARGINS = (0.0, 0.25, 0.5, 1.0, 2.0, 4.0)
T_MARGINS = (0.0, 2.0, 4.0, 6.0, 8.0, 10.0, 15.0)


def excess(cal, T: np.ndarray, Q: np.ndarray, i0: int, window_s: float) -> float:
    """How far (references' standard deviations) the touch's input lies beyond the references' range (≤ 0:
    inside; NaN: no input)."""
    V, ok = vectors(T[None], Q[None], i0, window_s, cal.sub)
    if not ok[0]:
        return float("nan")
    x = inputs(cal.center, cal.whiten, cal.scale, V)[0]
    return float(max(np.max(cal.x_lo - x), np.max(x - cal.x_hi)))


def fitted_T_excess(T: np.ndarray, Q: np.ndarray, i0: int, window_s: float) -> float:
    """How far (°C) the physics fit's object temperature (the form the slave chooses) lies outside the
    envelope's 5–50 °C (≤ 0: inside; NaN: no fit)."""
    probe = replace(mi.ProbeParams(), window_s=window_s)
    inp = mi.fit_input(T, Q, i0, mt.PERIOD_S, probe)
    chosen = mi.best_form([(f, mi.fit_form(inp, f, probe)) for f in mi.FORMS]) if inp is not None else None
    if chosen is None:
        return float("nan")
    lo, hi = ENVELOPE_T_OBJECT_C
    return float(max(lo - chosen[1].T_object0_C, chosen[1].T_object0_C - hi))


def measure(draws: list[dict], cores: dict) -> list[tuple[str, float, float, float, float]]:
    """(kind, early excess, late excess, early fitted-temperature excess, late one) per touch."""
    base = load_rig_params()
    rigs = {False: base, True: mt.other_tem(base)}
    sims = list(mt.SIM_TO_TABLE)
    names = [mt.SIM_TO_TABLE[m] for m in sims]
    cals = [load_calibration(ENVELOPE_EARLY), load_calibration(ENVELOPE_LATE)]
    out = []
    for t in draws:
        T, Q, i0, est, _ = me.simulate_drawn(rigs, t, sims, cores)
        early = replace(est, code=est.early_code, posterior=est.early_posterior) if est is not None else None
        right = tuple(me._answer(x, names) == t["class"] for x in (early, est))
        if i0 < 0:
            out.append((t.get("kind", "inside"),) + (float("nan"),) * 4 + right)
            continue
        e = [excess(c, T, Q, i0, win.window_s) for c, win in zip(cals, (EARLY, LATE))]
        f = [fitted_T_excess(T, Q, i0, win.window_s) for win in (EARLY, LATE)]
        out.append((t.get("kind", "inside"), e[0], e[1], f[0], f[1]) + right)
    return out


def _table(
    rows: list, kinds: list[str], what: str, cols: tuple[int, int], margins: tuple[float, ...]
) -> None:
    print(f"share of touches {what} (early / refined), r: how many of those the classifier had right")
    print(f"{'margin':>8s} " + " ".join(f"{k:>16s}" for k in kinds))
    for m in margins:
        cells = []
        for k in kinds:
            e = np.array([(r[cols[0]], r[cols[1]], r[5], r[6]) for r in rows if r[0] == k], float)
            hit = e[:, :2] > m
            # flagged, and of the flagged how many the classifier had right (what abstaining costs there)
            cells.append(
                f"{np.mean(hit[:, 0]):.2f}/{np.mean(hit[:, 1]):.2f} r{np.sum(hit[:, 0] & (e[:, 2] > 0)):d}"
                f"/{np.sum(hit[:, 1] & (e[:, 3] > 0)):d}"
            )
        print(f"{m:8.2f} " + " ".join(f"{c:>16s}" for c in cells))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.material_novelty_margin", description=__doc__)
    ap.add_argument("--touches", type=int, default=300)
    args = ap.parse_args(argv)
    cores = {True: me.after_identify(mt.other_tem(load_rig_params()))}
    ms.ENVELOPE_NOVELTY_MARGIN = ms.ENVELOPE_T_MARGIN_C = float("inf")  # the answers without the check
    rows = measure(mt.envelope_draws(args.touches, ENV_DEVELOPMENT), cores)
    rows += measure(mt.outside_draws(args.touches, mt.OUTSIDE_DEVELOPMENT), cores)
    kinds = ["inside"] + [k[0] for k in mt.OUTSIDE_KINDS]
    for k in kinds:
        e = np.array([(r[5], r[6]) for r in rows if r[0] == k], float)
        print(f"{k}: {len(e)} touches, right without a novelty check (early / refined) {e.mean(0).round(3)}")
    _table(rows, kinds, "beyond the references' input range by more than the margin (SD)", (1, 2), MARGINS)
    _table(
        rows, kinds, "whose fitted object lies beyond 5–50 °C by more than the margin (°C)", (3, 4), T_MARGINS
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
