"""``telethermo session``: a telepresence session of the two node processes with simulated rigs.

    telethermo session --scene sim/scenes/probe_touches_al_steel_wood.toml --out out/session

Starts our socketcand hub when no real bus is given (``--bus socketcan:vcan0`` uses a real one),
then the slave and the master node programs as separate processes with the scene (a virtual-material
scene runs the master alone, rendering); shows progress;
Ctrl-C stops everything cleanly (master, slave, hub: each node cuts its current and closes its
recording). Then it merges the two recordings (plus the scene's direct-touch reference), prints the
figures (the same as the offline runner's) and writes into ``--out``: ``recording.csv``,
``summary.json``, ``session.png``, and each node's ``master.csv``/``slave.csv`` and logs.
"""

from __future__ import annotations

import argparse
import math
import signal
import sys
import time
from collections.abc import Callable
from pathlib import Path

from telethermo import sim
from telethermo.nodes.iomodules import fill_truth
from telethermo.nodes.launch import LaunchError, NodePair, PairConfig
from telethermo.recording.merge import MergeError, merge_recordings
from telethermo.atomic import write_json_atomic
from telethermo.device.netconfig import NetworkConfigError, load_network
from telethermo.cli.main import EXIT_FAIL, EXIT_INTERRUPTED, EXIT_OK, UserError
from telethermo.cli.progress import Progress
from telethermo.cli.session_summary import print_summary
from telethermo.control.gainsfile import load_gains
from telethermo.control.material_lab import load_lab
from telethermo.ident import load_model
from telethermo.offline.figures import compute_figures
from telethermo.offline.plot import write_session_png
from telethermo.recording.format import RecordingError, write_recording_csv
from telethermo.recording.result import SessionRun
from telethermo.transport.bus import TransportError
from telethermo.transport.busargs import add_bus_arguments
from telethermo.transport.published import publish_if_absent, unpublish
from telethermo.transport.resolve import resolve_bus


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "session", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--scene", required=True, type=Path, help="scene file (TOML) or a shipped scene's name")
    p.add_argument(
        "--out", type=Path, default=Path("out/session"), help="output folder (default out/session)"
    )
    add_bus_arguments(p).description += (
        ". A session's bus joins two processes: when none is configured (or "
        "only network.toml's in-process virtual bus), the session starts our "
        "loopback hub"
    )
    p.add_argument(
        "--network", type=Path, help="network settings file (default: packaged bus_config/network.toml)"
    )
    p.add_argument(
        "--model",
        type=Path,
        help="identified TEM model file for both nodes (default: none; the flux estimator needs none)",
    )
    p.add_argument(
        "--gains",
        type=Path,
        help="tuned gains file of `telethermo tune --out` for both nodes (default: the shipped gains)",
    )
    p.add_argument(
        "--material-lab",
        type=Path,
        metavar="LAB.json",
        help="the slave's material lab file of `telethermo calibrate-material` (default: none)",
    )
    p.add_argument(
        "--timing",
        choices=["lockstep", "realtime"],
        default="lockstep",
        help="lockstep (default: as fast as the two processes go) or realtime (wall clock)",
    )
    p.add_argument(
        "--duration", type=float, metavar="S", help="run S seconds of scene time (default: the scene's)"
    )
    p.add_argument(
        "--seed", type=int, default=0, help="noise seed (master; the slave gets seed+1; default 0)"
    )
    p.add_argument(
        "--io",
        action="store_true",
        help="each side's rig behind a simulated CiA 401 I/O module (telethermo-iomodule, its "
        "own process); the controllers drive them with --rig io and the packaged RIG.toml: "
        "four nodes",
    )
    p.add_argument("--no-plot", action="store_true", help="do not write session.png")
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.set_defaults(func=run)


def _interrupt(signum, frame) -> None:
    """SIGTERM stops a session as Ctrl-C does (children stopped in order, figures of what ran)."""
    raise KeyboardInterrupt


def _resolve_scene(arg: Path):
    try:
        return sim.load_scene(arg)
    except ValueError as exc:  # SceneError: names the file and the field
        raise UserError(str(exc)) from None


def _session_bus(args: argparse.Namespace) -> str | None:
    """The two nodes' bus, resolved as every command resolves it (telethermo.transport.resolve, without
    a published hub: the session publishes its own); None = start our hub (nothing configured but
    network.toml's in-process virtual bus)."""
    try:
        net = load_network(args.network)
        rb = resolve_bus(
            net,
            bus=args.bus,
            interface=args.interface,
            channel=args.channel,
            bitrate=args.bitrate,
            use_published=False,
        )
    except (NetworkConfigError, TransportError) as exc:
        raise UserError(str(exc)) from None
    if rb.settings.interface != "virtual":
        return rb.settings.describe()
    if rb.source == str(net.path):
        return None
    raise UserError(
        f"{rb.settings.describe()} (from {rb.source}) exists inside one process only; the session's "
        "two node processes need socketcan, socketcand or no bus setting (then our hub)"
    )


def _node_file(option: str, path: Path | None, load: Callable[[Path], object]) -> list[str]:
    """``[option, path]`` for the node programs, the file read by ``load`` here first so that a bad one is
    refused with its field, not in a node's log ([] without a file)."""
    if path is None:
        return []
    try:
        load(path)
    except ValueError as exc:
        raise UserError(f"{option}: {exc}") from None
    return [option, str(path.resolve())]


def _checked_files(args: argparse.Namespace) -> list[str]:
    """Refuse a missing --network file and a missing or bad --model/--gains file here, with its field, not in
    two node logs; the gains arguments of the node programs."""
    if args.network is not None and not args.network.is_file():
        raise UserError(f"--network {str(args.network)!r}: no such file")
    if args.model is not None and not args.model.is_file():
        raise UserError(f"--model {str(args.model)!r}: no such file")
    _node_file("--model", args.model, load_model)  # read as the nodes read it (ModelFileError: file, field)
    return _node_file("--gains", args.gains, load_gains)


def _mode(args: argparse.Namespace, scene, scene_path: Path) -> str:
    """The nodes' mode for the scene: render for a virtual scene (refused with --io: the master takes its
    rendering script from the scene, which a --rig io node does not load), else telepresence."""
    mode = "render" if getattr(scene, "kind", "") == "virtual" else "telepresence"
    if args.io and mode == "render":
        raise UserError(
            f"--io: {scene_path}: a virtual (render) scene; --io runs telepresence scenes (the "
            "master renders from the scene's script only with its own simulated rig)"
        )
    return mode


def _print_modules(pair: NodePair) -> None:
    if pair.modules:
        print(
            "I/O modules: "
            + ", ".join(
                f"{r} node {m.node_id} (pid {m.proc.pid if m.proc else '-'})" for r, m in pair.modules.items()
            ),
            file=sys.stderr,
        )


def run(args: argparse.Namespace) -> int:
    scene = _resolve_scene(args.scene)
    scene_path = Path(getattr(scene, "path", args.scene))
    gains_args = _checked_files(args)
    if args.duration is not None and not (args.duration > 0 and math.isfinite(args.duration)):
        raise UserError(f"--duration {args.duration}: expected a number of seconds > 0")
    bus = _session_bus(args)
    duration = args.duration if args.duration is not None else scene.duration_s
    cycles = int(round(duration / scene.period_s))
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    mode = _mode(args, scene, scene_path)
    cfg = PairConfig(
        scene=scene_path,
        out_dir=out,
        bus=bus,
        network=args.network,
        model=args.model,
        mode=mode,
        timing=args.timing,
        cycles=cycles,
        seed=args.seed,
        progress_every=max(1, cycles // 100),
        master_args=gains_args,
        slave_args=gains_args + _node_file("--material-lab", args.material_lab, load_lab),
        io=args.io,
    )
    pair = NodePair(cfg)
    interrupted = published = False
    bar = None
    t0 = time.monotonic()
    old_int = signal.getsignal(signal.SIGINT)
    signal.signal(signal.SIGTERM, _interrupt)
    try:
        try:
            pair.start()
        except LaunchError as exc:
            print(f"telethermo session: error: {exc}", file=sys.stderr)
            return EXIT_FAIL
        published = _publish(pair)
        where = pair.bus if bus else f"{pair.bus} (our hub, pid {pair.hub.proc.pid})"
        if not args.quiet:
            _print_modules(pair)
            print(
                f"session {scene.name} ({mode}): {cycles} cycles of {scene.period_s * 1e3:g} ms, "
                f"{args.timing}, on {where}",
                file=sys.stderr,
            )
        if not args.quiet:
            bar = Progress("session", cycles, unit="cycles")
        _wait(pair, bar, cycles, t0)
    except KeyboardInterrupt:
        interrupted = True
        if bar is not None:
            bar.close()
        if not args.quiet:
            print("  interrupted: stopping master, slave and hub", file=sys.stderr)
    finally:
        if bar is not None:
            bar.close()
        if published:
            unpublish()
        codes = pair.stop()
        signal.signal(signal.SIGINT, old_int)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
    wall = time.monotonic() - t0
    failed = {r: c for r, c in codes.items() if r in ("master", "slave") and c not in (0, None)}
    if failed:
        print(f"telethermo session: node exit codes {failed}; logs in {out}", file=sys.stderr)
    return _report(
        pair,
        scene,
        out,
        wall,
        cycles,
        plot=not args.no_plot,
        code=EXIT_INTERRUPTED if interrupted else (EXIT_FAIL if failed else EXIT_OK),
    )


def _report(pair, scene, out: Path, wall_s: float, cycles: int, *, plot: bool, code: int) -> int:
    m = pair.recording("master")
    s = pair.recording("slave") if pair.slave is not None else None
    if not m.is_file() or (s is not None and not s.is_file()):
        print(f"telethermo session: no recordings in {out} (see the logs there)", file=sys.stderr)
        return code or EXIT_FAIL
    try:
        rec = merge_recordings(m, s, scene=scene)
        for mod in pair.modules.values():  # --io: the plant's truth is in the modules' processes
            fill_truth(rec, mod.truth_path)
            rec.meta.setdefault("scene", scene.name)
    except (MergeError, RecordingError, ValueError, OSError) as exc:
        print(f"telethermo session: error: {exc}", file=sys.stderr)
        return code or EXIT_FAIL
    figures = compute_figures(rec)
    run = SessionRun(
        transport=pair.bus.split("://")[0] if pair.bus else None,
        wall_time_s=wall_s,
        cycles=len(rec),
        cycles_requested=cycles,
        cycles_per_s=len(rec) / wall_s if wall_s > 0 else None,
        complete=len(rec) == cycles,
        master=pair.result,
        io_modules={r: mod.node_id for r, mod in pair.modules.items()} or None,
    )
    figures["run"] = run.to_dict()
    write_recording_csv(out / "recording.csv", rec)
    write_json_atomic(out / "summary.json", figures)
    if plot:
        try:
            write_session_png(out / "session.png", rec)
        except ImportError as exc:  # matplotlib is the optional 'plot' extra
            print(f"telethermo session: no plot ({exc})", file=sys.stderr)
    print_summary(figures)
    print(
        f"\nwritten: {out / 'recording.csv'}, {out / 'summary.json'}"
        + (f", {out / 'session.png'}" if plot else "")
    )
    return code


def _publish(pair: NodePair) -> bool:
    """Publish the session's bus for other terminals unless one is published; True if we did."""
    # a second terminal's `telethermo status` / `monitor` finds this session's bus with no flag, unless
    # a hub (or another session) published first: that one stays findable, during and after this session
    try:
        other = publish_if_absent(pair.bus, "telethermo session")
        if other is not None:
            print(
                f"telethermo session: {other.by} (pid {other.pid}) stays the bus other terminals find "
                f"({other.bus}); this session's nodes: --bus {pair.bus}",
                file=sys.stderr,
            )
        return other is None
    except OSError as exc:
        print(
            f"telethermo session: warning: cannot publish the bus ({exc}); "
            f"other terminals need --bus {pair.bus}",
            file=sys.stderr,
        )
        return False


def _wait(pair: NodePair, bar: Progress | None, cycles: int, t0: float) -> None:
    """Until the master ends (or the slave ends first), updating the progress bar; ``t0``: monotonic s."""
    while pair.master.poll() is None:
        time.sleep(0.2)
        if bar is not None:
            k, n = pair.progress
            bar.update(k, n or cycles, rate=k / max(1e-9, time.monotonic() - t0))
        if pair.slave is not None and pair.slave.poll() is not None and pair.master.poll() is None:
            if bar is not None:
                bar.close()
            print(
                f"telethermo session: the slave process ended (exit {pair.slave.returncode}); "
                f"see {pair.log('slave')}",
                file=sys.stderr,
            )
            break
