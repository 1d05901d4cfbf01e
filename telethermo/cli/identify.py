"""``telethermo identify``: run the identification experiment, fit, validate, and write the model or load it
into a live node.

    # a live node: load the model into it
    telethermo identify master --bus socketcand://127.0.0.1:29536/telethermo
    telethermo identify slave --samples 10000 --out slave_tem.json               # ... and keep a copy
    telethermo identify --out model.json                          # default simulated free pad
    telethermo identify --scene free_pad_identification --orders 4,4,1,1 --samples 10000 --out m.json

Prints a report (held-out worst-case free-run error, flux error, stability verdict) and writes the model
file atomically. An unstable model is refused: nothing is written or loaded and the exit code is 1.
The live path is :mod:`telethermo.cli.identify_live`; what both print, :mod:`telethermo.cli.identify_output`.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

from telethermo import sim
from telethermo.cli import common
from telethermo.cli.identify_live import parse_amplitude, run_live
from telethermo.cli.identify_output import print_report
from telethermo.cli.progress import Progress
from telethermo.cli.main import EXIT_FAIL, EXIT_OK, UserError
from telethermo.ident import NarmaOrders, UnstableModelError, save_model
from telethermo.ident.experiment import ExperimentSettings, Record, identify_rig, save_record_csv
from telethermo.ident.plots import plot_identification

DEFAULT_ORDERS = "4,4,1,1"


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "identify",
        description="Run a PRBS identification experiment on a pad that touches nothing, fit the NARMA "
        "temperature model (guiatni eq. 10) and the heat-flux model (eq. 12), validate on a "
        "held-out PRBS, check stability. With NODE: the experiment runs on that live node "
        "(IDENTIFY mode, its safety envelope active), its samples are recorded from the bus, "
        "and the model is loaded into the node by SDO (CRC-checked). Without NODE: on a "
        "simulated rig, and the model is written to --out.",
    )
    p.add_argument(
        "node", nargs="?", help="a live node: master, slave or a node-ID (omit for a simulated rig)"
    )
    common.add_bus_options(p)
    src = p.add_mutually_exclusive_group()
    src.add_argument(
        "--rig",
        choices=["sim"],
        default="sim",
        help="'sim': the default simulated free pad (sim.free_pad_rig)",
    )
    src.add_argument(
        "--scene",
        metavar="NAME_OR_TOML",
        help="use the master rig of this scene (its pad must touch nothing)",
    )
    p.add_argument(
        "--tem",
        metavar="TOML",
        help="simulated rig: its thermo-electric module, from a file in the format of the default "
        "sim/data/tem_15x15.toml ([datasheet] ratings and the rig's hardware) or from a [tem] table "
        "(the scene format)",
    )
    _add_experiment_args(p)
    p.add_argument(
        "--no-load", action="store_true", help="live node: identify only, do not load the model into it"
    )
    p.add_argument(
        "--force", action="store_true", help="live node: run even if its contact detector says touched"
    )
    p.add_argument(
        "--no-capacity",
        action="store_true",
        help="skip the steady-state capacity experiment (eq. 13; 14 steady states inside the envelope)",
    )
    p.add_argument(
        "--save-data",
        metavar="CSV",
        help="also write the experiment's samples (j, phase, t_s, current_A, "
        "T_sensor_C, Q_W) to this CSV file",
    )
    p.add_argument(
        "--plot", metavar="PNG", help="also plot measured vs predicted (held-out) and the capacity fit"
    )
    p.add_argument("--out", metavar="MODEL.json", help="model file to write (required without NODE)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def _add_experiment_args(p: argparse.ArgumentParser) -> None:
    """The experiment: PRBS lengths, model orders and fit, seed, the simulated rig's period and ambient."""
    p.add_argument(
        "--samples", type=int, default=10_000, help="training PRBS length, samples (default 10000)"
    )
    p.add_argument(
        "--validation", type=int, default=None, help="held-out PRBS length, samples (default samples/2)"
    )
    p.add_argument(
        "--orders",
        default=DEFAULT_ORDERS,
        metavar="n,m,p,q",
        help=f"NARMA orders (default {DEFAULT_ORDERS}: what the simulated rig's data justify; "
        "guiatni used 3,3,3,3)",
    )
    p.add_argument(
        "--method",
        choices=["oe", "ls"],
        default="oe",
        help="oe: least squares then output-error refinement (default); ls: least squares only",
    )
    p.add_argument(
        "--seed", type=int, default=0, help="PRBS seed (training seed, validation seed+1) and sim noise seed"
    )
    p.add_argument(
        "--period-s", type=float, default=0.01, help="sample period for --rig sim, s (default 0.01)"
    )
    p.add_argument("--ambient-C", type=float, default=25.0, help="ambient temperature for --rig sim, °C")
    p.add_argument("--rest", type=int, default=200, help="samples at 0 A before the PRBS (default 200)")
    p.add_argument(
        "--amplitude-A",
        default="0.1,1.0",
        metavar="LO,HI",
        help="range of the PRBS bit amplitudes, A (default 0.1,1.0)",
    )
    p.add_argument("--hold", type=int, default=25, help="samples each PRBS bit is held (default 25)")


def _check_sim_args(args: argparse.Namespace) -> tuple[ExperimentSettings, NarmaOrders, Path]:
    """The settings, orders and model file of an experiment on a simulated rig, or a UserError."""
    if not args.out:
        raise UserError("--out MODEL.json is required on a simulated rig (or name a live NODE)")
    if args.no_load or args.force:
        raise UserError("--no-load and --force are for a live NODE")
    try:
        settings = ExperimentSettings(
            rest_samples=args.rest, amplitude_A=parse_amplitude(args.amplitude_A), hold_samples=args.hold
        )
    except ValueError as exc:
        raise UserError(str(exc)) from None

    try:
        orders = NarmaOrders.parse(args.orders)
    except ValueError as exc:
        raise UserError(f"--orders: {exc}") from None
    if args.samples < 4 * orders.d + 200:
        raise UserError(
            f"--samples must be at least {4 * orders.d + 200} for orders {args.orders}, got {args.samples}"
        )
    if args.validation is not None and args.validation < 100:
        raise UserError(f"--validation must be at least 100 samples, got {args.validation}")
    out = Path(args.out)
    if out.exists() and out.is_dir():
        raise UserError(f"--out {out}: is a directory; expected a file name")
    return settings, orders, out


def _save_data(args: argparse.Namespace, rep: dict, settings: ExperimentSettings, meta: dict) -> None:
    """Write the experiment's samples to ``--save-data`` (CSV) and say so."""
    r = rep["record"]
    nan = np.full(len(r["T_C"]), np.nan)
    rec = Record(r["t_s"], r["current_A"], r["T_C"], r["Q_W"], nan, nan, rep["guard_interventions"])
    plan = settings.plan(seed=args.seed, train_samples=rep["n_train"], validation_samples=rep["n_validation"])
    print(f"samples written: {save_record_csv(args.save_data, rec, plan, comments={'rig': meta['rig']})}")


def _build_rig(args: argparse.Namespace):
    try:
        params = sim.load_tem_file(args.tem) if getattr(args, "tem", None) else None
    except ValueError as exc:
        raise UserError(str(exc)) from None
    if args.scene:
        try:
            scene = sim.load_scene(args.scene)
            scene = dataclasses.replace(scene, rig_params=params) if params is not None else scene
            rig = sim.build_rig(scene, "master", seed=args.seed)
        except (ValueError, OSError) as exc:
            raise UserError(str(exc)) from None
        touches = getattr(getattr(rig, "schedule", None), "touches", ())
        if touches:
            raise UserError(
                f"scene {args.scene}: the master pad touches {touches[0].body!r} at "
                f"{touches[0].start_s} s; identification needs a pad that touches nothing"
            )
        return rig, {"rig": "scene", "scene": str(args.scene)}
    if not (args.period_s > 0):
        raise UserError(f"--period-s must be > 0, got {args.period_s}")
    rig = sim.free_pad_rig(
        period_s=args.period_s, ambient_C=args.ambient_C, seed=args.seed, noise=True, params=params
    )
    return rig, {
        "rig": "sim.free_pad_rig",
        "period_s": args.period_s,
        "ambient_C": args.ambient_C,
        **({"tem": str(args.tem)} if params is not None else {}),
    }


@common.failures
def run(args: argparse.Namespace) -> int:
    if args.node is not None:
        if (
            args.scene
            or args.rig != "sim"
            or args.no_capacity
            or args.period_s != 0.01
            or args.ambient_C != 25.0
        ):
            raise UserError(
                "a live NODE takes no --scene/--rig/--period-s/--ambient-C/--no-capacity (its rig and "
                "SYNC period are the node's; the capacity experiment runs on simulated rigs only)"
            )
        return run_live(args)
    settings, orders, out = _check_sim_args(args)
    rig, meta = _build_rig(args)
    bar = None if args.quiet else Progress("identify: experiment", 0, unit="samples")

    def fitting_notice(done: int, total: int) -> None:
        if bar is not None:
            bar.update(done, total)
            if done >= total:
                bar.close()
                print(
                    "identify: fitting (least squares, output-error refinement, stability check) ...",
                    file=sys.stderr,
                    flush=True,
                )

    try:
        tem, rep = identify_rig(
            rig,
            n_samples=args.samples,
            n_validation=args.validation,
            orders=orders,
            seed=args.seed,
            progress=fitting_notice,
            method=args.method,
            meta=meta,
            capacity=not args.no_capacity,
            keep_record=bool(args.plot or args.save_data),
            settings=settings,
        )
    except UnstableModelError as exc:
        print(
            f"telethermo identify: {exc}; no model written (a longer experiment, --samples 10000 or more, "
            "gives a better-determined model)",
            file=sys.stderr,
        )
        return EXIT_FAIL
    print_report(rep, tem, ("master", "slave"))
    if not rep["stable"]:
        print(
            f"telethermo identify: model refused ({rep['stability_reason']}); no model written",
            file=sys.stderr,
        )
        return EXIT_FAIL
    save_model(out, tem)
    print(f"model written: {out}")
    if args.save_data:
        _save_data(args, rep, settings, meta)
    if args.plot:
        print(f"plot written: {plot_identification(args.plot, tem, rep)}")
    return EXIT_OK
