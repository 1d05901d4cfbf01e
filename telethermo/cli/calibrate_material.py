"""``telethermo calibrate-material``: calibrate the physics fit of this lab's probe from a handful of touches
of reference samples of known material (issue 23; docs/material_id.md, "Calibrating a lab's probe").

The input is the slave's own recordings (``--record`` of the slave node, or a session's recording.csv):
every touch in them (the slave's contact detector closing, ``s_contact``, after at least 0.05 s open) is
fitted over the early (0.3 s) and the refined (1.2 s) window from ``s_T_sensor_C`` and ``s_Q_W``, as the
slave's core fits it. Each recording holds touches of one material: ``--touch RECORDING:MATERIAL``
(repeatable) or a TOML file (``--touches FILE.toml``: ``[[touch]]`` tables with ``recording`` and
``material``, paths relative to the file). MATERIAL is a rendering-table name with an effusivity (pvc,
glass, stainless_steel, ...). The correction (telethermo.control.material_lab: affine or offset in ln b,
with the floors re-fitted from the residuals) is written to ``--out`` (JSON, atomically) and the slave
node applies it with ``--material-lab FILE``. Touch each reference sample a few times, firmly, for at
least 1.5 s: bench/material_lab_calibrate.py measured how many touches are enough.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

import numpy as np

from telethermo.cli.main import UserError
from telethermo.control import material_lab as ml
from telethermo.control import material_physics as mp
from telethermo.control.material_id import ProbeParams, load_effusivity_table, pre_samples
from telethermo.inputfile import InputFileError, Section, load_toml
from telethermo.recording import RecordingError, read_recording_csv
from telethermo.offline.material_touches import SIM_TO_TABLE

WINDOWS = (mp.EARLY.window_s, mp.LATE.window_s)


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "calibrate-material", description=__doc__.split("\n\n")[1].replace("\n", " ") if __doc__ else None
    )
    p.add_argument(
        "--touch",
        action="append",
        default=[],
        metavar="RECORDING:MATERIAL",
        help="a slave recording whose touches are all of MATERIAL (repeat)",
    )
    p.add_argument(
        "--touches", type=Path, metavar="FILE.toml", help="[[touch]] tables of recording and material"
    )
    p.add_argument("--out", type=Path, required=True, metavar="FILE.json", help="the lab file to write")
    p.set_defaults(func=run)


def parse_touch(text: str) -> tuple[Path, str]:
    """``RECORDING:MATERIAL`` (the last colon splits: a path may hold one)."""
    path, sep, material = text.rpartition(":")
    if not sep or not path or not material:
        raise UserError(f"--touch {text!r}: expected RECORDING:MATERIAL, e.g. pvc.csv:pvc")
    return Path(path), material


def touches_file(path: Path) -> list[tuple[Path, str]]:
    """The (recording, material) pairs of a ``--touches`` TOML file (paths relative to it)."""
    try:
        top = Section(
            path, "", load_toml(path, what="a touches file ([[touch]] recording, material)"), {"touch"}
        )
        items = top.list("touch", expected="a list of [[touch]] tables")
        out = []
        table = load_effusivity_table()
        for k, item in enumerate(items):
            t = Section(path, f"touch[{k}]", item, {"recording", "material"})
            material = t.str("material")
            if material not in table:
                raise UserError(f"{path}: [touch[{k}]] material: {_unknown(material, table)}")
            out.append((path.parent / t.str("recording"), material))
    except InputFileError as exc:
        raise UserError(str(exc)) from None
    return out


def _unknown(material: str, table: dict) -> str:
    """What was expected instead of ``material`` (a scene's name of a table material is pointed out)."""
    alias = SIM_TO_TABLE.get(material)
    hint = f" (the scenes' {material!r} is the table's {alias!r})" if alias and alias != material else ""
    return f"expected one of {', '.join(table)}, got {material!r}{hint}"


def recording_touches(path: Path) -> list[tuple[Any, Any]]:
    """The early and refined physics fits (None: none) of every touch of the slave recording ``path``."""
    try:
        rec = read_recording_csv(path)
    except RecordingError as exc:
        raise UserError(str(exc)) from None
    cols = ("s_T_sensor_C", "s_Q_W", "s_contact")
    missing = [c for c in cols if c not in rec.columns]
    if missing:
        raise UserError(f"{path}: header: expected the slave's columns {', '.join(cols)}, missing {missing}")
    T, Q, contact = (rec.col(c) for c in cols)
    dt = _period(path, rec)
    n_pre = pre_samples(ProbeParams(), dt)
    on = np.nan_to_num(contact) > 0.5
    out = []
    for i0 in np.flatnonzero(on[1:] & ~on[:-1]) + 1:
        if i0 < n_pre or on[i0 - n_pre : i0].any():
            continue  # the probe was not open long enough before: no pre-contact state
        fits = ml.touch_fits(T, Q, int(i0), dt, WINDOWS)
        for w, window_s in enumerate(WINDOWS):  # the contact must last the whole window (touch_fits: None
            if not on[i0 : i0 + int(round(window_s / dt))].all():  # when the samples end before it)
                fits[w] = None
        out.append(tuple(fits))
    return out


def _period(path: Path, rec) -> float:
    """The recording's period, s (its meta's period_s, else the median step of t_s)."""
    p = rec.meta.get("period_s")
    if not (isinstance(p, (int, float)) and math.isfinite(p) and p > 0):
        t = rec.col("t_s")
        p = float(np.median(np.diff(t))) if len(t) > 1 else math.nan
    if not (math.isfinite(p) and p > 0):
        raise UserError(f"{path}: meta period_s: expected a period > 0 s (or at least two rows of t_s)")
    return float(p)


def run(args: argparse.Namespace) -> int:
    table = load_effusivity_table()
    pairs = [parse_touch(x) for x in args.touch] + (touches_file(args.touches) if args.touches else [])
    if not pairs:
        raise UserError("no touches: give --touch RECORDING:MATERIAL (repeat) or --touches FILE.toml")
    for path, material in pairs:
        if material not in table:
            raise UserError(f"{path}: material: {_unknown(material, table)}")
    per: dict[str, list] = {}
    sources = []
    for path, material in pairs:
        fits = recording_touches(path)
        per.setdefault(material, []).extend(fits)
        sources.append({"recording": str(path), "material": material, "touches": len(fits)})
    windows = []
    for w, base in enumerate((mp.EARLY, mp.LATE)):
        touches = [
            ml.LabTouch(math.log(f[w].b), f[w].se_ln_b, table[m], m)
            for m, fits in per.items()
            for f in fits
            if f[w] is not None
        ]
        try:
            windows.append(ml.fit_window(touches, base.window_s, base) if touches else None)
        except ValueError as exc:
            raise UserError(str(exc)) from None
    if windows[0] is None:
        raise UserError(
            "no touch of the recordings has a physics fit over the 0.3 s window: nothing to calibrate"
        )
    lab = ml.LabCorrection(early=windows[0], late=windows[1])
    _summary(per, lab, table)
    ml.save_lab(args.out, lab, {"sources": sources})
    print(f"wrote {args.out}")
    return 0


def _summary(per: dict[str, list], lab: ml.LabCorrection, table: dict[str, float]) -> None:
    """Per window: the correction; per material: touches in, the fitted ln b's error before / after."""
    for w, win in enumerate((lab.early, lab.late)):
        if win is None:
            print(
                f"window {WINDOWS[w]:g} s: no touch with a fit (the refined answer keeps the shipped "
                "calibration)"
            )
            continue
        why = f" ({win.why})" if win.why else ""
        print(
            f"window {win.window_s:g} s: {win.model}{why}: "
            f"ln b = {win.offset_ln:+.3f} + {win.scale:.3f}·ln b_fit, "
            f"floor {win.floor_ln:.3f}, interval floor {win.floor_ci_ln:.3f}, {win.n_touches} touches"
        )
        for m, fits in per.items():
            x = np.array([math.log(f[w].b) for f in fits if f[w] is not None])
            y = math.log(table[m])
            if x.size == 0:
                print(f"  {m:16s} 0 of {len(fits)} touches with a fit")
                continue
            before = float(np.sqrt(np.mean((x - y) ** 2)))
            after = float(np.sqrt(np.mean((win.ln_b(x) - y) ** 2)))
            print(f"  {m:16s} {x.size} of {len(fits)} touches: ln b error (RMS) {before:.3f} -> {after:.3f}")
