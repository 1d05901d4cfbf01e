"""``telethermo tune``: tune the bilateral pair's gains on a scene, offline, robustly.

    telethermo tune --scene probe_touches_al_steel_wood --budget 80 --out gains.json

Runs offline sessions (telethermo.offline.run_offline_session) of the scene and of a perturbed variant
(another room, finger, force and objects; --no-perturbed to skip it), searches the log-gains of both
sides with bounded Nelder-Mead (or --method de) within --budget evaluations, then checks the best
few points at ±30 % on each gain and keeps the one with the best worst case. Prints progress, the
candidates and the sensitivity table of the chosen point, and writes the gains file (JSON, atomic;
format in docs/tuning.md; ``telethermo.control.gainsfile.load_gains`` reads it) and, with --record,
the run's full record (every evaluation; ``python -m bench.tune`` puts it into bench/results/tuning.json).
Each evaluation costs one offline session per scene (≈ 1 s each for 30 s of scene on this VM).
The tuner itself is :mod:`telethermo.tuning`.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path
from typing import Any

from telethermo import sim
from telethermo import tuning as tn
from telethermo.atomic import write_json_atomic
from telethermo.cli.main import EXIT_OK, EXIT_USAGE, UserError
from telethermo.offline.transparency import LATE_S


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "tune", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--scene", required=True, help="telepresence scene: a TOML file or a shipped scene's name")
    p.add_argument(
        "--budget",
        type=int,
        default=60,
        help="search points (default 60; each costs 3 evaluations: the point and its two stress corners; "
        "the robustness check adds (2·gains + corners)·(candidates + 1) more)",
    )
    p.add_argument("--out", type=Path, help="write the tuned gains here (JSON, atomic)")
    p.add_argument(
        "--method",
        choices=["nelder-mead", "de"],
        default="nelder-mead",
        help="bounded Nelder-Mead from the shipped gains (default) or differential evolution",
    )
    p.add_argument(
        "--seed", type=int, default=0, help="seed of the sessions' noise and of the optimiser (default 0)"
    )
    p.add_argument(
        "--start",
        type=Path,
        metavar="GAINS.json",
        help="start the search from a gains file (e.g. an earlier --out; default: the shipped gains)",
    )
    _add_robustness_args(p)
    p.add_argument(
        "--duration", type=float, metavar="S", help="run S seconds of each scene (default: the scene's)"
    )
    _add_weight_args(p)
    p.add_argument("--no-perturbed", action="store_true", help="tune on the scene alone (not recommended)")
    p.add_argument(
        "--envelope",
        type=int,
        default=0,
        metavar="N",
        help="also average over N scenes drawn across the operating envelope (room 15-32 °C, objects "
        "5-50 °C, force 0.5-20 N, finger ±30 %%, noise ×1-3; the shipped TEM: other modules get "
        "these gains through the gain rule after identify). Seeded apart from the envelope "
        "benchmark's evaluation draws",
    )
    p.add_argument(
        "--record",
        type=Path,
        metavar="RUN.json",
        help="also write the run's full record here (every evaluation, the candidates, the sensitivity "
        "tables; JSON, atomic)",
    )
    p.add_argument("--quiet", action="store_true", help="no per-evaluation progress")
    p.set_defaults(func=run)


def _add_robustness_args(p: argparse.ArgumentParser) -> None:
    """The robustness box: candidates, its size and corners, the stress corners of the search."""
    p.add_argument(
        "--candidates", type=int, default=3, help="distinct best points checked for robustness (default 3)"
    )
    p.add_argument(
        "--rel", type=float, default=0.3, help="relative half-width of the robustness box (default 0.3)"
    )
    p.add_argument("--corners", type=int, default=4, help="random corners of the box checked (default 4)")
    p.add_argument(
        "--stress",
        type=float,
        metavar="REL",
        help="relative size of the stress corners the search minimises over (default: --rel; 0: the "
        "centre alone)",
    )


#: the objective's weights on the command line: option, its :class:`~telethermo.tuning.Weights` field (the
#: default), what it weighs and its unit
WEIGHT_OPTIONS = (
    ("--w-early", "early_per_C", "the transparency early mean error", "1/°C"),
    ("--w-late", "late_per_C", "the transparency late mean error", "1/°C"),
    ("--w-tracking", "tracking_per_C", "the steady tracking RMS", "1/°C"),
    ("--w-margin", "margin_per_C", "the discrimination margin shortfall", "1/°C"),
    ("--w-limit", "limit_per_s", "the time at envelope limits", "1/s"),
)


def _add_weight_args(p: argparse.ArgumentParser) -> None:
    """The weights of the tuning objective's terms (:data:`WEIGHT_OPTIONS`)."""
    w = tn.Weights()
    for option, field, what, unit in WEIGHT_OPTIONS:
        default = getattr(w, field)
        p.add_argument(
            option,
            type=float,
            default=default,
            metavar="W",
            help=f"weight of {what}, {unit} (default {default:g})",
        )


def _fmt(x: Any, nd: int = 3) -> str:
    if isinstance(x, bool):
        return "yes" if x else "NO"
    if isinstance(x, float):
        return "nan" if not math.isfinite(x) else f"{x:.{nd}f}"
    return str(x)


def _table(headers: list[str], rows: list[list[Any]]) -> str:
    cells = [headers] + [[_fmt(c) for c in r] for r in rows]
    w = [max(len(r[i]) for r in cells) for i in range(len(headers))]
    lines = ["  ".join(c.rjust(w[i]) if i else c.ljust(w[i]) for i, c in enumerate(r)) for r in cells]
    lines.insert(1, "  ".join("-" * x for x in w))
    return "\n".join(lines)


def _row(label: str, ev) -> list[Any]:
    s = ev.summary()
    return [
        label,
        ev.J,
        s["early_C"],
        s["late_C"],
        s["tracking_rms_C"],
        s["margin_shortfall_C"],
        s["limit_s"],
        s["trips"],
        s["order_kept"],
    ]


HEADERS = ["point", "J", "early °C", "late °C", "track °C", "margin short °C", "limit s", "trips", "order"]


def _check(args: argparse.Namespace) -> None:
    """UserError for an argument out of its range."""
    if args.budget < 1:
        raise UserError(f"--budget {args.budget}: expected an integer >= 1")
    if not (0 < args.rel < 1):
        raise UserError(f"--rel {args.rel}: expected a number in (0, 1)")
    if args.stress is not None and not (0 <= args.stress < 1):
        raise UserError(f"--stress {args.stress}: expected a number in [0, 1)")
    if args.candidates < 1 or args.corners < 0:
        raise UserError("--candidates must be >= 1 and --corners >= 0")
    if args.duration is not None and not (args.duration > 0 and math.isfinite(args.duration)):
        raise UserError(f"--duration {args.duration}: expected a number of seconds > 0")


def _start_gains(path: Path | None) -> dict[str, float] | None:
    """--start: the gains file's gains as {"role.field": value}, or None (the shipped gains)."""
    if path is None:
        return None
    try:
        loaded = tn.load_gains(path)
    except ValueError as exc:
        raise UserError(f"--start: {exc}") from None
    return {f"{role}.{k}": v for role, gains in loaded.items() for k, v in gains.items()}


def _weights(args: argparse.Namespace) -> tn.Weights:
    """The objective's weights given by the :data:`WEIGHT_OPTIONS` (UserError for one < 0 or not finite)."""
    weights = {}
    for option, field, _, _ in WEIGHT_OPTIONS:
        v = getattr(args, option[2:].replace("-", "_"))
        if not (v >= 0 and math.isfinite(v)):
            raise UserError(f"{option} {v}: expected a finite number >= 0")
        weights[field] = v
    return tn.Weights(**weights)


def _report(res: tn.TuneResult, obj: tn.Objective, rel: float, wall: float) -> None:
    """Print the candidates, the sensitivity table of the chosen point and the search's totals."""
    print("\ncandidates (centre J, worst J over the ±%d %% box, the worst point):" % round(rel * 100))
    pool = res.candidates + (
        [res.reference] if res.reference is not None and res.reference not in res.candidates else []
    )
    rows = []
    for rob in pool:
        tag = "reference (shipped)" if rob is res.reference else "candidate"
        tag += " *chosen*" if rob is res.chosen else ""
        rows.append(
            [tag, rob.centre.J, rob.worst.J, rob.worst_label] + [rob.centre.gains[k] for k in obj.keys]
        )
    print(_table(["point", "J", "worst J", "worst at"] + obj.keys, rows))
    print(f"\nsensitivity of the chosen point (±{rel:.0%} on each gain, then random corners):")
    print(
        _table(HEADERS, [_row("centre", res.chosen.centre)] + [_row(lab, ev) for lab, ev in res.chosen.rows])
    )
    print("\nchosen gains: " + ", ".join(f"{k} = {v:.4g}" for k, v in res.best.gains.items()))
    print(
        f"search: {res.search.method}, budget {res.search.budget} points, {len(res.search.points)} points, "
        f"{res.search.n_evaluations} evaluations; "
        f"{len(obj.history)} evaluations in all ({obj.n_sessions} sessions), wall time {wall:.0f} s"
    )


def _write(path: Path, what: str, doc: dict[str, Any], writer) -> None:
    try:
        writer(path, doc)
    except OSError as exc:
        raise UserError(f"{what} {str(path)!r}: {exc}") from None
    print(f"wrote {path}")


def _check_duration(duration_s: float | None, scene) -> None:
    """UserError for a ``--duration`` that ends before the scene's first touch is scored: its late window
    (t_on + LATE_S[1] s) and the tracking in steady contact need it, or every evaluation scores J = 100
    (a non-finite figure) and the run writes meaningless gains."""
    touches = scene.slave_contacts
    if duration_s is None or not touches:
        return
    need = min(c.start_s for c in touches) + LATE_S[1]
    if duration_s < need:
        raise UserError(
            f"--duration {duration_s:g}: expected >= {need:g} s for scene {scene.name}: its first touch "
            f"(t_on {min(c.start_s for c in touches):g} s) is scored up to {LATE_S[1]:g} s after it"
        )


def run(args: argparse.Namespace) -> int:
    _check(args)
    try:
        scene = sim.load_scene(args.scene)
        _check_duration(args.duration, scene)  # before the tuning scenes are built: a refusal costs nothing
        scenes = tn.tuning_scenes(scene, perturbed=not args.no_perturbed, envelope=max(0, args.envelope))
    except ValueError as exc:  # SceneError names the file and the field; a virtual scene is refused
        raise UserError(str(exc)) from None
    x0 = _start_gains(args.start)
    weights = _weights(args)

    t0 = time.perf_counter()
    best = [math.inf]

    def progress(ev, n: int) -> None:
        if ev.J < best[0]:
            best[0] = ev.J
        if not args.quiet:
            s = ev.summary()
            print(
                f"  eval {n:4d}  J {ev.J:7.3f}  (best {best[0]:.3f})  early {s['early_C']:.3f} °C  "
                f"track {s['tracking_rms_C']:.3f} °C  [{time.perf_counter() - t0:6.1f} s]",
                flush=True,
            )

    obj = tn.Objective(scenes, seed=args.seed, duration_s=args.duration, progress=progress, weights=weights)
    print(
        f"telethermo tune: scenes {', '.join(s.name for s in scenes)}; gains "
        f"{', '.join(f'{s.key} [{s.lo:g}, {s.hi:g}]' for s in obj.space)}",
        flush=True,
    )
    if x0 is not None:
        x0 = {k: v for k, v in x0.items() if k in obj.keys}
    res = tn.tune(
        obj,
        budget=args.budget,
        method=args.method,
        seed=args.seed,
        candidates=args.candidates,
        x0=x0,
        rel=args.rel,
        corners=args.corners,
        stress_rel=args.stress,
        on_stage=lambda m: print(f"- {m}", flush=True),
    )
    wall = time.perf_counter() - t0
    _report(res, obj, args.rel, wall)

    doc = tn.gains_document(res, obj, extra={"wall_time_s": wall})
    if args.out is not None:
        _write(args.out, "--out", doc, tn.write_gains)
    if args.record is not None:
        record = tn.run_record(
            res,
            obj,
            doc,
            scene=scene.name,
            budget=args.budget,
            method=args.method,
            seed=args.seed,
            rel=args.rel,
            corners=args.corners,
            wall_time_s=wall,
        )
        _write(args.record, "--record", record, write_json_atomic)
    return EXIT_OK


def main(argv: list[str] | None = None) -> int:
    """Run ``telethermo tune`` standalone (``python -m telethermo.cli.tune``; bench.tune calls it too)."""
    ap = argparse.ArgumentParser(prog="telethermo")
    sub = ap.add_subparsers(dest="command")
    register(sub)
    args = ap.parse_args(["tune", *(sys.argv[1:] if argv is None else argv)])
    try:
        return int(args.func(args) or 0)
    except UserError as exc:
        print(f"telethermo tune: error: {exc}", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":
    raise SystemExit(main())
