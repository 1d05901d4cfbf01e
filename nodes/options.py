"""Command line of the node programs (``telethermo-master``, ``telethermo-slave``).

Both programs take the same options; only the defaults differ (node-ID, SYNC production, mode).
Values not given on the command line come from the network settings file (bus_config/network.toml).
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from typing import Any
from pathlib import Path

from telethermo.control.types import Mode, Role
from telethermo.inputfile import InputFileError, parse_toml
from telethermo.nodes.realtime import RealtimeOptions, parse_cpus
from telethermo.sim.errors import SceneError
from telethermo.sim.scene import scene_path
from telethermo.transport.busargs import add_bus_arguments

MODE_NAMES = {
    "idle": Mode.IDLE,
    "telepresence": Mode.TELEPRESENCE,
    "render": Mode.RENDER,
    "identify": Mode.IDENTIFY,
}


class OptionError(ValueError):
    """A bad option or file; the message names it and says what was expected (exit 2)."""


@dataclass(frozen=True)
class NodeOptions:
    """What one node process runs.

    Attributes:
        role: master or slave.
        node_id: CANopen node-ID 1..127 (None: from the network settings).
        network: network settings file (None: the packaged bus_config/network.toml).
        bus: transport override, ``INTERFACE:CHANNEL`` or ``socketcand://HOST:PORT/CHANNEL``.
        interface, channel, bitrate: ``-i/-c/-b`` (python-can's names); see telethermo.transport.resolve.
        scene: scene file of a simulated rig (lockstep by default).
        rig: ``module:factory`` of a hardware rig driver (real time).
        rig_config: TOML file whose top-level keys are the rig factory's keyword arguments (a driver's port,
            gains, calibration), or None.
        rig_args: ``--rig-arg KEY=VALUE`` settings, over those of ``rig_config``.
        model: identified model file (None: no model; the flux estimator needs none).
        gains: tuned gains file of `telethermo tune` (None: the shipped defaults); telepresence mode only.
        material_lab: the slave's material lab file of `telethermo calibrate-material` (None: the shipped
            calibration of the physics fit; telethermo.control.material_lab).
        mode: initial mode (changeable by SDO on object 0x2500).
        record: CSV file for this node's signals (None: no recording).
        timing: "lockstep" (SYNC k+1 after every node's cycle-k PDO) or "realtime" (wall clock).
        produce_sync: this node is the SYNC producer (and the NMT master of the pair).
        cycles: SYNC producer: stop after this many cycles (None: the scene's duration; 0: until stopped).
        seed: seed of the simulated rig's noise (None: the scene's).
        wait_peer_s: SYNC producer: wait this long for the peer's boot before starting anyway, s.
        progress_every: print ``progress K N`` every this many cycles (0: never).
        json: the SYNC producer ends with one ``result {json}`` line on stdout instead of the summary table.
        verbose: log at INFO level.
        recover: only turn the journal of ``record`` left by a killed node into ``record``, then exit.
        store: the node's CiA 301 store file (0x1010/0x1011; None:
            ``$XDG_STATE_HOME/telethermo/node<ID>.json``).
    """

    role: Role
    node_id: int | None = None
    network: Path | None = None
    bus: str | None = None
    interface: str | None = None
    channel: str | None = None
    bitrate: int | None = None
    scene: Path | None = None
    rig: str | None = None
    rig_config: Path | None = None
    rig_args: tuple[tuple[str, Any], ...] = ()
    realtime: RealtimeOptions = RealtimeOptions()
    model: Path | None = None
    gains: Path | None = None
    material_lab: Path | None = None
    mode: Mode = Mode.TELEPRESENCE
    record: Path | None = None
    timing: str | None = None
    produce_sync: bool = False
    cycles: int | None = None
    seed: int | None = None
    wait_peer_s: float = 30.0
    progress_every: int = 0
    json: bool = False
    log: Path | None = None
    verbose: bool = False
    recover: bool = False
    store: Path | None = None


def build_parser(role: Role) -> argparse.ArgumentParser:
    other = "slave" if role is Role.MASTER else "master"
    what = (
        "thermal display under the operator's finger; produces SYNC by default"
        if role is Role.MASTER
        else "robotic thermal probe; follows the master's SYNC by default"
    )
    p = argparse.ArgumentParser(
        prog=f"telethermo-{role}",
        description=f"The telethermo {role} CANopen node ({what}). On each SYNC: read the rig, run the "
        f"control core, apply the current, send TPDO1 (estimate, heat flux) to the {other}. "
        "SIGINT/SIGTERM stop it cleanly (current to zero, last heartbeat, recording flushed).",
        epilog="exit codes: 0 ok (also a stop by SIGINT/SIGTERM, Ctrl-C), 1 runtime failure, "
        "2 bad option or file",
    )
    p.add_argument("--node-id", type=int, help="CANopen node-ID 1..127 (default: from the network settings)")
    p.add_argument(
        "--network", type=Path, help="network settings file (default: packaged bus_config/network.toml)"
    )
    add_bus_arguments(p)
    _add_rig_arguments(p)
    _add_run_arguments(p)
    _add_realtime_arguments(p)
    p.add_argument(
        "--store",
        type=Path,
        metavar="FILE.json",
        help="the node's parameter store (CiA 301 0x1010 save / 0x1011 restore defaults; "
        "`telethermo save NODE`): read at boot, written on save (default: "
        "$XDG_STATE_HOME/telethermo/node<ID>.json, ~/.local/state/... when unset)",
    )
    p.add_argument("--log", type=Path, help="also write the log to this file")
    p.add_argument("-v", "--verbose", action="store_true", help="log at INFO level")
    return p


def _add_rig_arguments(p: argparse.ArgumentParser) -> None:
    """What the node drives and with what: the simulated or hardware rig, its settings, model and gains."""
    rig = p.add_mutually_exclusive_group()  # one of them is required, except with --recover
    rig.add_argument(
        "--scene", type=Path, help="scene file (TOML) or the name of a shipped scene: simulated rig"
    )
    rig.add_argument(
        "--rig",
        metavar="MODULE:FACTORY",
        help="hardware rig: FACTORY(**settings) returns a telethermo.rig.Rig; io: CANopen I/O "
        "modules described by --rig-config RIG.toml (docs/hardware.md)",
    )
    p.add_argument(
        "--rig-config",
        type=Path,
        metavar="FILE.toml",
        help="settings of the --rig driver: the TOML file's top-level keys are FACTORY's keyword arguments",
    )
    p.add_argument(
        "--rig-arg",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="one setting of the --rig driver (repeatable; over --rig-config's): VALUE is read as a TOML "
        'value (2.5, true, "text") or else taken as text, e.g. --rig-arg port=/dev/ttyUSB0',
    )
    p.add_argument(
        "--model",
        type=Path,
        help="identified model file (default: none; the flux estimator, the default, "
        "needs none; `telethermo identify` or a model file loads one)",
    )
    p.add_argument(
        "--gains",
        type=Path,
        help="tuned gains file written by `telethermo tune --out` "
        "(telepresence gains of this node's role; default: the shipped ones)",
    )
    p.add_argument(
        "--material-lab",
        type=Path,
        metavar="FILE.json",
        help="slave: this probe's calibration of the material identification's physics fit, written by "
        "`telethermo calibrate-material --out` (default: the shipped probe's)",
    )


def _add_run_arguments(p: argparse.ArgumentParser) -> None:
    """How the node runs: its mode, recording, timing, SYNC production, length and output."""
    p.add_argument(
        "--mode",
        choices=list(MODE_NAMES),
        default=None,
        help="initial mode (default: telepresence); object 0x2500 changes it by SDO",
    )
    p.add_argument(
        "--record",
        type=Path,
        help="write this node's signals to this CSV file (journaled in "
        "FILE.journal, synced every 0.5 s, while the node runs)",
    )
    p.add_argument(
        "--recover",
        action="store_true",
        help="with --record FILE: turn FILE.journal, left by a node that was killed, into FILE "
        "(every complete row) and exit; the next start with --record FILE does it by itself, "
        "into FILE's stem + .killed-<UTC time>",
    )
    p.add_argument(
        "--timing",
        choices=["lockstep", "realtime"],
        help="lockstep (default with --scene) or realtime (default with --rig)",
    )
    sync = p.add_mutually_exclusive_group()
    sync.add_argument(
        "--sync",
        dest="produce_sync",
        action="store_true",
        default=None,
        help="produce SYNC (default for the master)",
    )
    sync.add_argument("--no-sync", dest="produce_sync", action="store_false", help="do not produce SYNC")
    p.add_argument(
        "--cycles",
        type=int,
        help="SYNC producer: stop after N cycles (default: the scene's duration; 0 = until SIGINT/SIGTERM)",
    )
    p.add_argument("--seed", type=int, help="noise seed of the simulated rig")
    p.add_argument(
        "--wait-peer",
        type=float,
        default=30.0,
        metavar="S",
        help="SYNC producer: wait up to S s for the peer's boot-up before starting (default 30)",
    )
    p.add_argument("--progress", type=int, default=0, metavar="K", help="print 'progress k n' every K cycles")
    p.add_argument(
        "--json",
        action="store_true",
        help="SYNC producer: end with one 'result {json}' line on stdout (for programs: the "
        "launcher of telethermo session reads it) instead of the summary table",
    )


def _add_realtime_arguments(p: argparse.ArgumentParser) -> None:
    """The real-time knobs of a lab PC (telethermo.nodes.realtime)."""
    rt = p.add_argument_group(
        "real time (lab PC; each knob is applied as far as the system permits, else a warning)"
    )
    rt.add_argument("--cpu", metavar="N[,M]", help="pin the node to these CPUs (e.g. 1, or 2,3)")
    rt.add_argument(
        "--rt-priority", type=int, metavar="P", help="SCHED_FIFO priority 1..99 (needs CAP_SYS_NICE)"
    )
    rt.add_argument("--nice", type=int, metavar="N", help="nice value -20..19 (negative needs CAP_SYS_NICE)")
    rt.add_argument("--mlock", action="store_true", help="lock the node's memory (no page faults in a cycle)")
    rt.add_argument(
        "--gc",
        choices=["default", "freeze"],
        default="default",
        help="freeze: move start-up objects out of the garbage collector, rarer generation-0 runs",
    )


def _scene_file(arg: Path | None) -> Path | None:
    """--scene: a scene file, or the name of a shipped scene (as ``telethermo session`` takes it)."""
    if arg is None:
        return None
    try:
        path = scene_path(arg)
    except SceneError as exc:
        raise OptionError(f"--scene {str(arg)!r}: {exc}") from None
    if not path.is_file():
        raise OptionError(f"--scene {str(arg)!r}: no such file")
    return path


def _realtime_options(args: argparse.Namespace) -> RealtimeOptions:
    try:
        cpus = parse_cpus(args.cpu) if args.cpu is not None else None
    except ValueError as exc:
        raise OptionError(str(exc)) from None
    if args.rt_priority is not None and not 1 <= args.rt_priority <= 99:
        raise OptionError(f"--rt-priority {args.rt_priority}: expected 1..99")
    if args.nice is not None and not -20 <= args.nice <= 19:
        raise OptionError(f"--nice {args.nice}: expected -20..19")
    return RealtimeOptions(
        cpus=cpus,
        rt_priority=args.rt_priority,
        nice=args.nice,
        mlock=args.mlock,
        gc_freeze=args.gc == "freeze",
    )


def options_from_args(role: Role, args: argparse.Namespace) -> NodeOptions:
    """Validate the parsed arguments (files exist, ranges) into :class:`NodeOptions`."""

    def existing(path: Path | None, what: str) -> Path | None:
        if path is not None and not path.is_file():
            raise OptionError(f"{what} {str(path)!r}: no such file")
        return path

    if args.recover:
        if args.record is None:
            raise OptionError("--recover needs --record FILE (the recording whose journal to recover)")
        return NodeOptions(role=role, record=args.record, recover=True, log=args.log, verbose=args.verbose)
    if args.scene is None and args.rig is None:
        raise OptionError("one of the arguments --scene --rig is required")
    if args.node_id is not None and not 1 <= args.node_id <= 127:
        raise OptionError(f"--node-id {args.node_id}: expected 1..127")
    if args.cycles is not None and args.cycles < 0:
        raise OptionError(f"--cycles {args.cycles}: expected >= 0")
    if args.rig is not None and ":" not in args.rig and args.rig != "io":
        raise OptionError(f"--rig {args.rig!r}: expected MODULE:FACTORY or io (CANopen I/O modules)")
    if args.rig_config is not None and args.rig is None:
        raise OptionError("--rig-config: settings of a hardware rig driver, only with --rig")
    if args.rig_arg and args.rig is None:
        raise OptionError("--rig-arg: a setting of a hardware rig driver, only with --rig")
    if not args.wait_peer >= 0:
        raise OptionError(f"--wait-peer {args.wait_peer}: expected >= 0 s")
    produce_sync = args.produce_sync if args.produce_sync is not None else role is Role.MASTER
    timing = args.timing or ("lockstep" if args.scene is not None else "realtime")
    if timing == "lockstep" and args.scene is None and args.rig != "io":
        raise OptionError(
            "--timing lockstep needs a simulated rig (--scene) or simulated I/O modules "
            "(--rig io): hardware runs in real time"
        )
    mode = MODE_NAMES[args.mode] if args.mode else (Mode.TELEPRESENCE)
    if mode is Mode.RENDER and role is Role.SLAVE:
        raise OptionError("--mode render: virtual rendering runs on the master alone")
    if args.record is not None and args.record.exists() and args.record.is_dir():
        raise OptionError(f"--record {str(args.record)!r}: is a directory, expected a CSV file path")
    if args.store is not None and args.store.is_dir():
        raise OptionError(f"--store {str(args.store)!r}: is a directory, expected a file path (FILE.json)")
    return NodeOptions(
        role=role,
        node_id=args.node_id,
        network=existing(args.network, "--network"),
        bus=args.bus,
        interface=args.interface,
        channel=args.channel,
        bitrate=args.bitrate,
        scene=_scene_file(args.scene),
        rig=args.rig,
        rig_config=existing(args.rig_config, "--rig-config"),
        rig_args=tuple(rig_arg(a) for a in args.rig_arg),
        realtime=_realtime_options(args),
        model=existing(args.model, "--model"),
        gains=existing(args.gains, "--gains"),
        material_lab=existing(args.material_lab, "--material-lab"),
        mode=mode,
        record=args.record,
        timing=timing,
        produce_sync=produce_sync,
        cycles=args.cycles,
        seed=args.seed,
        wait_peer_s=args.wait_peer,
        progress_every=max(0, args.progress),
        json=args.json,
        log=args.log,
        verbose=args.verbose,
        store=args.store,
    )


def rig_arg(text: str) -> tuple[str, Any]:
    """``KEY=VALUE`` of ``--rig-arg``: VALUE as a TOML value when it is one (2.5, true, "x", [1, 2]),
    else text."""
    key, sep, value = text.partition("=")
    key = key.strip()
    if not sep or not key.isidentifier():
        raise OptionError(
            f"--rig-arg {text!r}: expected KEY=VALUE with KEY a Python identifier (e.g. port=/dev/ttyUSB0)"
        )
    try:
        return key, parse_toml(f"v = {value}", "--rig-arg")["v"]
    except InputFileError:  # not a TOML value: the text itself
        return key, value
