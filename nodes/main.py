"""The body of ``telethermo-master`` and ``telethermo-slave``: options -> network settings -> rig ->
device -> run until done or signalled -> clean stop.

Exit codes: 0 ok (including a stop by SIGINT/SIGTERM), 1 runtime failure, 2 bad option or file.
A SYNC producer prints ``progress K N`` lines on stdout when asked (``--progress``); the summary of
the run is logged at exit.
"""

from __future__ import annotations

import logging
import sys
import time
from typing import Callable

import numpy as np

from telethermo.device.netconfig import NetworkConfigError, load_network
from telethermo.control.types import Mode, Role
from telethermo.recording.format import header_comments, node_columns
from telethermo.recording.journal import CsvRecorder, RecorderError, recover_journal
from telethermo.iomodule.iorig import IoRig
from telethermo.recording.result import IoRigCounters, RealtimeFigures, RunResult
from telethermo.device.eds_info import EdsError, EdsInfo
from telethermo.transport.bus import TransportError
from telethermo.transport.resolve import ResolvedBus, resolve_bus

from telethermo.nodes.options import OptionError, build_parser, options_from_args
from telethermo.nodes.parts import build_parts
from telethermo.nodes.realtime import apply_realtime
from telethermo.nodes.runtime import NodeRuntime
from telethermo.stopsignal import StopOnSignal

EXIT_OK, EXIT_FAIL, EXIT_USAGE = 0, 1, 2


def _setup_logging(role: Role, verbose: bool, log_path) -> None:
    fmt = f"%(asctime)s telethermo-{role} %(levelname)s %(message)s"
    handlers: list[logging.Handler] = [logging.StreamHandler(sys.stderr)]
    handlers[0].setLevel(logging.INFO if verbose else logging.WARNING)
    if log_path is not None:
        log_path.parent.mkdir(parents=True, exist_ok=True)
        fh = logging.FileHandler(log_path, mode="a", encoding="utf-8")
        fh.setLevel(logging.INFO)
        handlers.append(fh)
    logging.basicConfig(level=logging.INFO, format=fmt, handlers=handlers, force=True)
    # python-can's socketcand client warns about every TCP read that ends mid-frame (normal under load), and
    # logs a lost hub as an ERROR with a whole traceback: the reconnecting bus (transport.resilient) says
    # it in one line ("bus ... lost: ...; retrying", then "bus ... back")
    logging.getLogger("can.interfaces.socketcand.socketcand").setLevel(logging.CRITICAL)


def run_node(role: Role, argv: list[str] | None = None) -> int:
    args = build_parser(role).parse_args(argv)
    prog = f"telethermo-{role}"
    try:
        opts = options_from_args(role, args)
    except OptionError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    _setup_logging(role, opts.verbose, opts.log)
    log = logging.getLogger("telethermo.node")
    if opts.recover:
        return _recover(prog, opts.record)

    try:
        net = load_network(opts.network)
        resolved = resolve_bus(
            net, bus=opts.bus, interface=opts.interface, channel=opts.channel, bitrate=opts.bitrate
        )
        transport = resolved.settings
        node_id = opts.node_id or net.node(role).node_id
        EdsInfo(net.node(role).eds)  # a damaged EDS is a bad file (exit 2, its line), not a failed start
        parts = build_parts(opts, period_s=net.sync.period_s, node_id=node_id, transport=transport)
    except (OptionError, NetworkConfigError, TransportError, EdsError) as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return EXIT_USAGE

    recorder = final_comments = None
    if opts.record is not None:
        try:
            recorder, final_comments = _recorder(role, opts, parts, node_id, transport.describe())
        except OSError as exc:  # RecorderError: the journal is held by a running node; no space; ...
            print(f"{prog}: error: --record {opts.record}: {exc}", file=sys.stderr)
            return EXIT_USAGE

    lockstep = opts.timing == "lockstep"
    rt = NodeRuntime(
        role,
        node_id,
        net,
        transport,
        parts,
        mode=opts.mode,
        lockstep=lockstep,
        produce_sync=opts.produce_sync,
        recorder=recorder,
        store_path=opts.store,
    )
    rt.final_comments = final_comments
    return _serve(prog, rt, opts, parts, log, warning=_virtual_bus_warning(prog, resolved))


def _virtual_bus_warning(prog: str, resolved: ResolvedBus) -> str | None:
    """The line a node on python-can's in-process ``virtual`` bus prints once it runs (None on any other
    bus): a node program is a process of its own (run_node installs the signal handlers, so it is the main
    thread), and no other process (its peer node, ``telethermo get``, a session) can join that bus."""
    ts = resolved.settings
    if ts.interface != "virtual":
        return None
    return (
        f"{prog}: warning: {ts.describe()} (from {resolved.source}) is a bus inside this process only: "
        "no other process (the peer node, telethermo get/monitor) can reach this node; start "
        "telethermo-hub in another terminal and restart this node (it then needs no flag), or give "
        "--bus socketcan:can0 (or -i/-c, CAN_INTERFACE/CAN_CHANNEL, ~/.canrc)"
    )


def _serve(
    prog: str, rt: NodeRuntime, opts, parts, log: logging.Logger, *, warning: str | None = None
) -> int:
    """Start the node, run it until it is done or signalled (SIGINT/SIGTERM), then stop it and close its
    rig; the exit code (a failed start or a cycle error: 1). ``warning``: a line printed once the node runs,
    after its ready line."""
    reason = ["finished"]

    def on_signal(name: str) -> None:  # from StopOnSignal's watcher thread, which then sets stop_event
        reason[0] = name

    with StopOnSignal(rt.stop_event, on_signal=on_signal):
        return _run(prog, rt, opts, parts, log, reason, warning)


def _run(
    prog: str,
    rt: NodeRuntime,
    opts,
    parts,
    log: logging.Logger,
    reason: list[str],
    warning: str | None,
) -> int:
    """:func:`_serve`'s body, inside its signal context."""
    role, node_id, transport = rt.role, rt.node_id, rt.transport
    code = EXIT_OK
    try:
        try:
            rt.start()
        except Exception as exc:  # the bus cannot be opened, the hub is not there, ...
            print(
                f"{prog}: error: cannot start node {node_id} on {transport.describe()}: {exc}",
                file=sys.stderr,
            )
            code = EXIT_FAIL
            return code
        print(_ready_line(role, node_id, transport.describe(), opts), file=sys.stderr, flush=True)
        if warning is not None:
            print(warning, file=sys.stderr, flush=True)
        # after start-up: what is frozen/locked is the running node
        for note in apply_realtime(opts.realtime):
            (log.warning if note.startswith("WARNING") else log.info)(note.removeprefix("WARNING "))
        if opts.produce_sync:
            _produce(rt, opts, parts, log)
        else:
            while not rt.stop_event.wait(0.5):
                pass
        if rt.stats.cycle_errors:
            code = EXIT_FAIL
    finally:
        rt.stop(reason[0])
        close_rig = getattr(parts.rig, "close", None)
        if callable(close_rig):
            close_rig()
    return code


def _recorder(role: Role, opts, parts, node_id: int, transport: str) -> tuple[CsvRecorder, Callable | None]:
    """The node's recording (its side's columns and the SYNC cycle), streamed through the journal, and the
    source of its final comment lines (render scenes: the meta is final at the end), or None."""
    columns = node_columns("m" if role is Role.MASTER else "s")
    meta = dict(
        parts.meta,
        period_s=parts.period_s,
        mode=opts.mode.name.lower(),
        rounding="real32",
        node_id=node_id,
        timing=opts.timing,
        transport=transport,
    )
    recorder = CsvRecorder(opts.record, columns, comments=header_comments(meta, allow_nan=True))
    if parts.render_script is None:
        return recorder, None
    # the render script measures each touch's finger temperature as it goes: the meta is final at the end
    script = parts.render_script
    return recorder, lambda: header_comments(dict(meta, render=script.meta()), allow_nan=True)


def _produce(rt: NodeRuntime, opts, parts, log: logging.Logger) -> None:
    """The SYNC producer's run: wait for the peer (telepresence), run the cycles, print the result line."""
    if opts.mode is not Mode.TELEPRESENCE:
        pass  # rendering / identification / idle: the peer is welcome but not awaited
    elif not rt.wait_for_peer(opts.wait_peer_s):
        if not rt.stop_event.is_set():
            log.warning("peer %d not seen within %g s: starting anyway", rt.peer_id, opts.wait_peer_s)
    cycles = opts.cycles if opts.cycles is not None else (parts.cycles or 0)

    def progress(k: int, n: int) -> None:
        print(f"progress {k} {n}", flush=True)

    t0 = time.perf_counter()
    done = rt.run_producer(cycles, progress_every=opts.progress_every, progress=progress)
    wall = time.perf_counter() - t0
    log.info("SYNC producer: %d of %d cycles run in %.3f s", done, cycles, wall)
    result = run_result(rt, done, wall)
    print(result.to_line() if opts.json else summary_table(result), flush=True)


def _ready_line(role: Role, node_id: int, bus: str, opts) -> str:
    """What a terminal says once the node runs: on which bus, and what it waits for."""
    if not opts.produce_sync:
        return f"node {node_id} ready on {bus}, waiting for the master's SYNC"
    if opts.mode is Mode.TELEPRESENCE and opts.wait_peer_s > 0:
        peer = "slave" if role is Role.MASTER else "master"
        return f"node {node_id} ready on {bus}, waiting for the {peer}"
    return f"node {node_id} ready on {bus}, producing SYNC ({opts.mode.name.lower()})"


def summary_table(r: RunResult) -> str:
    """The producer's :func:`run_result` as a terminal shows it: a few lines, not 1 kB of JSON
    (that is ``--json``)."""

    def ms(v: float | None) -> str:
        return "-" if v is None else f"{v:.2f} ms"

    rate, rt = r.cycles_per_s, r.realtime
    rows = [
        (
            "cycles",
            f"{r.cycles} in {r.wall_s:.1f} s ({'-' if rate is None else f'{rate:,.0f}'}/s, "
            f"{r.timing}, period {r.period_s * 1e3:g} ms)",
        ),
        (
            "late cycles",
            f"{r.late_cycles}"
            + (f" (worst {ms(rt.lateness_ms_max)}, {rt.overruns} overruns)" if rt is not None else ""),
        ),
        ("lockstep timeouts", str(r.lockstep_timeouts)),
        ("SYNC -> TPDO", f"p50 {ms(r.sync_to_tpdo_ms_p50)}, p99 {ms(r.sync_to_tpdo_ms_p99)}"),
        ("cycle time", f"p50 {ms(r.cycle_ms_p50)}, p99 {ms(r.cycle_ms_p99)}"),
        ("EMCY raised", str(r.emcy_raised)),
    ]
    if r.io_rig is not None:
        rows.append(
            (
                "I/O rig",
                f"{r.io_rig.input_timeouts} input timeouts, {r.io_rig.module_restarts} module restarts",
            )
        )
    return "\n".join(f"  {k:<18} {v}" for k, v in rows) + "\n  (--json: all figures as one JSON line)"


def _recover(prog: str, record) -> int:
    """``--record FILE --recover``: the journal a killed node left becomes FILE; nothing else runs."""
    try:
        path = recover_journal(record)
    except RecorderError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return EXIT_FAIL
    print(f"recovered {path}", flush=True)
    return EXIT_OK


def run_result(rt, cycles: int, wall_s: float) -> RunResult:
    """The SYNC producer's summary of ``cycles`` run in ``wall_s`` seconds (``--json``: one ``result {json}``
    line on stdout)."""

    def pct(xs, q):
        return float(np.percentile(np.asarray(xs) * 1e3, q)) if xs else None

    s, tk = rt.stats, rt.ticker
    realtime = (
        None
        if tk is None
        else RealtimeFigures(
            lateness_ms_p50=pct(tk.stats.lateness_s, 50),
            lateness_ms_p99=pct(tk.stats.lateness_s, 99),
            lateness_ms_max=tk.stats.max_lateness_s * 1e3,
            overruns=tk.stats.overruns,
            late_tolerance_ms=tk.tolerance_s * 1e3,
        )
    )
    io_rig = None
    if isinstance(rt.parts.rig, IoRig):  # --rig io: its counters (0x2709, 0x270A) read now
        rt.rig_counters()
        io_rig = IoRigCounters(input_timeouts=s.input_timeouts, module_restarts=s.module_restarts)
    return RunResult(
        cycles=cycles,
        wall_s=wall_s,
        cycles_per_s=cycles / wall_s if wall_s > 0 else None,
        timing="lockstep" if rt.lockstep else "realtime",
        period_s=rt.parts.period_s,
        late_cycles=s.late_cycles,
        lockstep_timeouts=s.lockstep_timeouts,
        sync_to_tpdo_ms_p50=pct(s.latencies_s, 50),
        sync_to_tpdo_ms_p99=pct(s.latencies_s, 99),
        sync_to_tpdo_n=len(s.latencies_s),
        cycle_ms_p50=pct(s.cycle_s, 50),
        cycle_ms_p99=pct(s.cycle_s, 99),
        emcy_raised=s.emcy_raised,
        peer=rt.peer.counters.__dict__,
        bus=dict(rt.bus.stats.__dict__) if rt.bus is not None else None,
        realtime=realtime,
        io_rig=io_rig,
    )
