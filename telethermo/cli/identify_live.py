"""``telethermo identify NODE``: the identification experiment on a live node, over the bus.

What it does, as a CANopen configuration tool would (every step by SDO, on any python-can bus):

1. checks the node: OPERATIONAL, its pad touching nothing (0x2004 contact), the SYNC running;
   a peer in telepresence is put in idle for the time of the experiment (and put back);
2. writes the plan (0x2800..0x2806: seed, rest/training/held-out samples, amplitudes, hold);
3. maps the samples into three synchronous TPDOs (CiA 301 dynamic mapping: PDO invalid, mapping
   written, PDO valid), each carrying the sample number with one value: TPDO2 = (ident_sample,
   T_sensor_C), TPDO3 = (ident_sample, current_A), TPDO4 = (ident_sample, Q_W), on every SYNC;
4. sets mode 3 (IDENTIFY): the node's control core runs the plan under its safety envelope
   (:mod:`telethermo.ident.plan`), and this command records every value from the bus by its sample
   number; a value lost on the bus is fetched again by SDO from the node's record (0x280B..0x280E);
   a record in which the envelope cut the current, or with the pad touched at any time of the experiment
   (its contact flag, 0x2004, read every :data:`CONTACT_POLL_S` while it runs), is refused;
5. fits and validates the models on the record (:func:`telethermo.ident.experiment.fit_experiment`,
   the same as offline), prints the report, refuses an unstable model;
6. loads the model into the node while it still holds 0 A in IDENTIFY (0x2300..0x2311 by SDO, REAL64
   coefficients; 0x230D = 1) and checks the node's CRC-32 of what it runs (0x230F) against the one of
   what was sent;
7. puts back the node's mode, the PDO parameters it changed and the peer's mode (also on Ctrl-C or a
   failure: Ctrl-C waits for this step).

The remote-node side (SDO by name, the PDO remapping, the stream, samples fetched again, the model load)
is :mod:`telethermo.remote`; this module is the command's sequence and what it says.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import signal
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import canopen
import numpy as np

from telethermo.device.netconfig import NetworkConfig
from telethermo.cli import common
from telethermo.cli.identify_output import print_report
from telethermo.cli.identify_record import check_record
from telethermo.cli.progress import Progress
from telethermo.cli.main import EXIT_FAIL, EXIT_OK, UserError
from telethermo.control.types import Mode
from telethermo.ident import NarmaOrders, UnstableModelError, save_model
from telethermo.ident.experiment import ExperimentSettings, Record, fit_experiment, save_record_csv
from telethermo.ident.plan import IdentifyPlan
from telethermo.ident.plots import plot_identification
from telethermo.remote import pdo
from telethermo.remote.client import NodeClient
from telethermo.remote.errors import Failure
from telethermo.remote.heartbeat import HeartbeatWatch, heartbeat_wait_s, watch_heartbeats
from telethermo.remote.identify import IDENT_STATE_NAMES, STREAM, Stream, fetch_lost, load_model, write_plan
from telethermo.remote.targets import Target, lookup, node_targets, resolve_node

#: how often the pad's contact flag (0x2004) is read by SDO while the experiment runs, s (a touch shorter than
#: this may go unseen; one that disturbs a fit lasts longer)
CONTACT_POLL_S = 0.1

PLAN_KEYS = (
    "ident_seed",
    "ident_rest_samples",
    "ident_train_samples",
    "ident_validation_samples",
    "ident_amplitude_min_A",
    "ident_amplitude_max_A",
    "ident_hold_samples",
)


@dataclass
class Changes:
    """What this command changed on the bus, to put back: the node's mode, its TPDOs (saved whole before the
    first change; ``touched``: those it started to change, restored and only they) and the peers' modes."""

    client: NodeClient
    mode0: int
    saved: dict[int, pdo.TpdoSettings] = field(default_factory=dict)
    touched: list[int] = field(default_factory=list)
    peers: list[tuple[NodeClient, int]] = field(default_factory=list)


def parse_amplitude(text: str) -> tuple[float, float]:
    """``--amplitude-A LO,HI`` -> (lo, hi), A; UserError otherwise."""
    try:
        lo, hi = (float(x) for x in text.split(","))
    except ValueError:
        raise UserError(f"--amplitude-A: expected LO,HI in A (e.g. 0.1,1.0), got {text!r}") from None
    if not (0.0 <= lo <= hi and math.isfinite(hi)):
        raise UserError(f"--amplitude-A: expected 0 <= LO <= HI, A; got {text!r}")
    return lo, hi


def run_live(args: argparse.Namespace) -> int:
    """``telethermo identify NODE``; SIGTERM (a kill, a batch system's stop) is handled like Ctrl-C: the
    node is put back before the command ends."""
    if threading.current_thread() is not threading.main_thread():
        return _run_live(args)

    def on_term(signum, frame):
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGTERM, on_term)
    try:
        return _run_live(args)
    finally:
        signal.signal(signal.SIGTERM, old)


def _settings(args: argparse.Namespace, target: Target) -> tuple[NarmaOrders, IdentifyPlan, Path | None]:
    """The orders, the plan and the model file of the command line, checked before the bus is touched."""
    try:
        orders = NarmaOrders.parse(args.orders)
    except ValueError as exc:
        raise UserError(f"--orders: {exc}") from None
    lo, hi = parse_amplitude(args.amplitude_A)
    n_val = args.validation if args.validation is not None else max(args.samples // 2, 1)
    try:
        plan = IdentifyPlan(
            seed=args.seed,
            rest_samples=args.rest,
            train_samples=args.samples,
            validation_samples=n_val,
            amplitude_A=(lo, hi),
            hold_samples=args.hold,
        )
    except ValueError as exc:
        raise UserError(str(exc).replace("IdentifyPlan.", "plan: ")) from None
    if args.samples < 4 * orders.d + 200:
        raise UserError(
            f"--samples must be at least {4 * orders.d + 200} for orders {args.orders}, got {args.samples}"
        )
    if orders.d > 48:
        raise UserError(
            f"--orders {args.orders}: {orders.d} parameters; a node holds at most 48 (object 0x2310)"
        )
    for key in PLAN_KEYS:
        lookup(target, key)  # an EDS without the identification objects: say so before touching the node
    out = Path(args.out) if args.out else None
    if out is not None and out.exists() and out.is_dir():
        raise UserError(f"--out {out}: is a directory; expected a file name")
    return orders, plan, out


def _run_live(args: argparse.Namespace) -> int:
    net = common.network(args)
    target = resolve_node(net, args.node)
    orders, plan, out = _settings(args, target)
    with common.canopen_network(args, net) as nw:
        hb = watch_heartbeats(nw)
        changes = _check_node(nw, net, hb, target, args)
        stream = None
        try:
            _idle_peers(nw, net, hb, changes, args.timeout)
            write_plan(changes.client, plan)
            stream = _start_stream(nw, changes, plan)
            rec, meta = _experiment(nw, changes.client, plan, stream, args, net)
            return _fit_and_load(args, changes.client, plan, orders, rec, meta, out, net.sync.period_s)
        finally:
            # put back what this command changed; Ctrl-C waits for it
            with _sigint_deferred():
                with contextlib.suppress(Exception):
                    nw.bus.set_filters(None)
                if stream is not None:
                    for c in stream.field_of:
                        nw.unsubscribe(c)
                _restore(changes)


def _check_node(
    nw: canopen.Network, net: NetworkConfig, hb: HeartbeatWatch, target: Target, args: argparse.Namespace
) -> Changes:
    """The node runs on this bus, OPERATIONAL, not identifying already, its pad in air (or --force)."""
    if not hb.wait_for(lambda: target.node_id in hb.last, heartbeat_wait_s(net) + 1.0):
        raise Failure(f"{target.role} (node {target.node_id}) sends no heartbeat: is it running on this bus?")
    state = hb.state_name(target.node_id)
    if state != "OPERATIONAL":
        raise Failure(
            f"{target.role} (node {target.node_id}) is {state}: identification runs on its SYNC "
            f"cycle (start it: telethermo nmt start {target.role})"
        )
    client = NodeClient(nw, target, args.timeout)
    mode0 = int(client.get("mode"))
    if mode0 == int(Mode.IDENTIFY):
        raise Failure(f"{target.role} is already in identify mode (another identification running?)")
    if int(client.get("contact")) and not args.force:
        raise Failure(
            f"{target.role}: its pad is touched (contact = 1); identification needs a pad in air "
            "(lift the finger or the probe), or --force"
        )
    return Changes(client, mode0)


def _idle_peers(
    nw: canopen.Network, net: NetworkConfig, hb: HeartbeatWatch, changes: Changes, timeout_s: float
) -> None:
    """A peer in telepresence goes idle while its partner runs a PRBS (put back by :func:`_restore`)."""
    for t in node_targets(net):
        if t.node_id != changes.client.t.node_id and t.node_id in hb.last:
            try:
                peer = NodeClient(nw, t, timeout_s)
                pmode = int(peer.get("mode"))
            except (Failure, UserError):
                continue
            if pmode == int(Mode.TELEPRESENCE):
                changes.peers.append((peer, pmode))
                peer.set("mode", int(Mode.IDLE))
                print(
                    f"{t.role} (node {t.node_id}): telepresence -> idle for the experiment", file=sys.stderr
                )


def _start_stream(nw: canopen.Network, changes: Changes, plan: IdentifyPlan) -> Stream:
    """Save every stream TPDO whole, then remap each (CiA 301: invalid while the mapping changes), and
    receive only what the command needs from now on."""
    client = changes.client
    for comm, mp, _ in STREAM:
        changes.saved[comm] = pdo.read_tpdo(client, comm, mp)
    cobs = []
    for comm, _, entries in STREAM:
        changes.touched.append(comm)
        new = pdo.remapped(changes.saved[comm], entries, transmission_type=1)
        pdo.configure(client, new)
        cobs.append(new.can_id)
    stream = Stream(cobs, plan.total)
    # only what this command needs from now on (in the kernel on SocketCAN): the stream, SDO responses,
    # heartbeats; a reader that also parsed every SYNC and PDO of a lockstep session falls behind on a slow
    # computer
    nw.bus.set_filters(
        [{"can_id": c, "can_mask": 0x7FF, "extended": False} for c in cobs]
        + [
            {"can_id": 0x580, "can_mask": 0x780, "extended": False},
            {"can_id": 0x700, "can_mask": 0x780, "extended": False},
        ]
    )
    for c in cobs:
        nw.subscribe(c, stream.on_frame)
    return stream


def _experiment(
    nw: canopen.Network,
    client: NodeClient,
    plan: IdentifyPlan,
    stream: Stream,
    args: argparse.Namespace,
    net: NetworkConfig,
) -> tuple[Record, dict]:
    """Run the plan in IDENTIFY mode and record it from the bus (lost samples fetched by SDO); the record
    and its provenance. Failure if samples are missing or the record is not of a free pad at full current."""
    period_s = net.sync.period_s
    lo, hi = plan.amplitude_A
    print(
        f"identify {client.t.role} (node {client.t.node_id}): {plan.total} samples "
        f"({plan.rest_samples} rest + {plan.train_samples} training + {plan.validation_samples} held-out, "
        f"{lo:g}..{hi:g} A, {plan.hold_samples} samples per bit) at {period_s * 1e3:g} ms "
        f"({plan.total * period_s:.0f} s in real time)",
        file=sys.stderr,
    )
    t0 = time.perf_counter()
    client.set("mode", int(Mode.IDENTIFY))
    touches = _wait(stream, client, plan, period_s, quiet=args.quiet)
    t_exp = time.perf_counter() - t0
    nw.bus.set_filters(None)
    fetched = fetch_lost(stream, client, plan, notice=_notice)
    if stream.missing() or stream.duplicates:
        raise Failure(
            f"{stream.missing()} of {plan.total} samples missing and {stream.duplicates} "
            "values repeated on the bus; nothing fitted or loaded: run again"
        )
    guard = int(client.get("ident_guard"))
    start_cycle = int(client.get("ident_start_cycle"))
    check_record(stream, client, plan, touches, period_s, force=args.force)
    print(
        "identify: fitting (least squares, output-error refinement, stability check) ...",
        file=sys.stderr,
        flush=True,
    )
    rec = Record(
        t_s=np.arange(plan.total) * period_s,
        current_A=stream.I_A.copy(),
        T_C=stream.T_C.copy(),
        Q_W=stream.Q_W.copy(),
        T_sink_C=np.full(plan.total, np.nan),
        Q_true_W=np.full(plan.total, np.nan),
        guard_interventions=guard,
    )
    meta = {
        "rig": "live node",
        "node": client.t.role,
        "node_id": client.t.node_id,
        "bus": common.transport(args, net).describe(),
        "start_cycle": start_cycle,
        "samples_fetched_by_sdo": fetched,
        "experiment_wall_s": t_exp,
    }
    return rec, meta


def _notice(text: str) -> None:
    print(f"identify: {text}", file=sys.stderr, flush=True)


def _fit_and_load(
    args: argparse.Namespace,
    client: NodeClient,
    plan: IdentifyPlan,
    orders: NarmaOrders,
    rec: Record,
    meta: dict,
    out: Path | None,
    period_s: float,
) -> int:
    """Fit and validate the models on the record (the node holds 0 A in IDENTIFY, its plan done), report,
    write what was asked, and load the model into the node while it still holds 0 A there."""
    t = client.t
    t_exp = meta.pop("experiment_wall_s")
    settings = ExperimentSettings(
        rest_samples=plan.rest_samples, amplitude_A=plan.amplitude_A, hold_samples=plan.hold_samples
    )
    try:
        tem, rep = fit_experiment(
            rec,
            plan=plan,
            orders=orders,
            period_s=period_s,
            settings=settings,
            method=args.method,
            meta=meta,
            keep_record=bool(args.plot),
            source="telethermo identify (live node)",
        )
    except UnstableModelError as exc:
        print(
            f"telethermo identify: {exc}; no model written or loaded (a longer experiment, --samples 10000 "
            "or more, or lower orders give a better-determined model)",
            file=sys.stderr,
        )
        return EXIT_FAIL
    rep["experiment_wall_s"] = t_exp
    rep["samples_fetched_by_sdo"] = meta["samples_fetched_by_sdo"]
    if args.save_data:
        path = save_record_csv(
            args.save_data,
            rec,
            plan,
            comments={**meta, "plan": plan.as_dict(), "guard_interventions": rec.guard_interventions},
        )
        print(f"samples written: {path}", file=sys.stderr)
    print_report(rep, tem, (t.role,) if t.role in ("master", "slave") else ("master", "slave"))
    if not rep["stable"]:
        print(
            f"telethermo identify: model refused ({rep['stability_reason']}); nothing written or loaded",
            file=sys.stderr,
        )
        return EXIT_FAIL
    if out is not None:
        save_model(out, tem)
        print(f"model written: {out}")
    if args.plot:
        print(f"plot written: {plot_identification(args.plot, tem, rep)}")
    if args.no_load:
        print(f"{t.role}: model not loaded (--no-load)")
    else:
        crc = load_model(client, tem)
        print(f"model loaded into {t.role} (node {t.node_id}): CRC-32 0x{crc:08X} verified")
    return EXIT_OK


@contextlib.contextmanager
def _sigint_deferred():
    """Ctrl-C while putting a node back would leave it half-configured: hold SIGINT until the block is done,
    then raise it (main thread only; elsewhere a no-op)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught = []
    old = signal.signal(signal.SIGINT, lambda *_: caught.append(1))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)
        if caught:
            raise KeyboardInterrupt


def _wait(
    stream: Stream, client: NodeClient, plan: IdentifyPlan, period_s: float, *, quiet: bool
) -> list[tuple[int, bool]]:
    """Until every sample arrived, or the node says the experiment is done (samples lost on the bus are
    fetched afterwards); Failure if the node stops running it or interrupts it. Returns the contact flag read
    every :data:`CONTACT_POLL_S` meanwhile: (the sample number then reached, flag)."""
    bar = None if quiet else Progress("identify: experiment", plan.total, unit="samples")
    stall_s = max(5.0, 50 * period_s)
    last_n, last_t, last_poll, last_touch = -1, time.monotonic(), 0.0, 0.0
    touches: list[tuple[int, bool]] = []
    while True:
        with stream.cond:
            stream.cond.wait_for(lambda: stream.complete >= plan.total, CONTACT_POLL_S)
            n, top, done = stream.count, stream.highest, stream.complete
        if bar is not None:
            bar.update(min(top, plan.total))
        if done >= plan.total:
            if bar is not None:
                bar.close()
            return touches
        now = time.monotonic()
        if now - last_touch >= CONTACT_POLL_S:
            last_touch = now
            touches.append((top, bool(int(client.get("contact")))))
        if n != last_n:
            last_n, last_t = n, now
        if now - last_poll > 1.0:
            last_poll = now
            st = int(client.get("ident_state"))
            if st == 2 and now - last_t > 0.5:
                return touches  # done, its last frames lost: fetched by SDO
            if st == 3 or (st == 0 and now - last_t > stall_s):
                mode = int(client.get("mode"))
                raise Failure(
                    f"{client.t.role}: the experiment was interrupted (ident_state "
                    f"{IDENT_STATE_NAMES.get(st, st)}, mode {mode}) after {top} of {plan.total} samples"
                )
        if now - last_t > stall_s:
            raise Failure(
                f"{client.t.role}: no identification sample for {stall_s:.0f} s after {top} of "
                f"{plan.total} (is the SYNC producer running?)"
            )


def _restore(changes: Changes) -> None:
    """The node's mode, the TPDOs this command changed (from their saved parameters, never read again) and the
    peers' modes, as they were. Every step is tried, each SDO twice, and a failing one does not stop the rest;
    what could not be put back is said on stderr."""
    problems = []

    def attempt(what: str, fn, *a) -> None:
        for _ in range(2):
            try:
                fn(*a)
                return
            except (Failure, UserError) as exc:
                err = exc
        problems.append(f"{what}: {err}")

    client = changes.client
    attempt(f"{client.t.role} mode", client.set, "mode", changes.mode0)
    for comm in changes.touched:
        for index, sub, value in pdo.configure_writes(changes.saved[comm]):
            attempt(f"TPDO 0x{comm:04X}", client.raw_set, index, sub, value)
    for peer, pmode in changes.peers:
        attempt(f"{peer.t.role} mode", peer.set, "mode", pmode)
    for p in problems:
        print(
            f"telethermo identify: could not restore {p} (NMT reset node restores the power-on settings)",
            file=sys.stderr,
        )
