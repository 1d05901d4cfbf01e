"""``telethermo identify NODE``: the identification experiment on a live node, over the bus.

What it does, as a CANopen configuration tool would (every step by SDO, on any python-can bus):

1. checks the node: OPERATIONAL, its pad touching nothing (0x2004 contact), the SYNC running;
   a peer in telepresence is put in idle for the time of the experiment (and put back);
2. writes the plan (0x2800..0x2806: seed, rest/training/held-out samples, amplitudes, hold);
3. maps the samples into two synchronous TPDOs (CiA 301 dynamic mapping: PDO invalid, mapping
   written, PDO valid): TPDO2 = (T_sensor_C, current_A), TPDO3 = (ident_sample, Q_W), both on
   every SYNC;
4. sets mode 3 (IDENTIFY): the node's control core runs the plan under its safety envelope
   (:mod:`telethermo.ident.plan`), and this command records every sample from the bus, in order,
   by its sample number (a lost frame is a missing number: the run is refused, nothing loaded);
5. puts back the node's mode, PDO parameters and the peer's mode (also on Ctrl-C or failure);
6. fits and validates the models on the record (:func:`telethermo.ident.experiment.fit_experiment`,
   the same as offline), prints the report, refuses an unstable model;
7. loads the model into the node (0x2300..0x2311 by SDO, REAL64 coefficients; 0x230D = 1) and
   checks the node's CRC-32 of what it runs (0x230F) against the one of what was sent.
"""
from __future__ import annotations

import argparse
import math
import struct
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from telethermo.cli import common
from telethermo.cli.main import EXIT_FAIL, EXIT_OK, UserError
from telethermo.control.types import Mode

TPDO2_COMM, TPDO3_COMM, TPDO2_MAP, TPDO3_MAP = 0x1801, 0x1802, 0x1A01, 0x1A02
PDO_INVALID = 1 << 31
#: the identification stream: TPDO2 and TPDO3 mappings (index << 16 | sub << 8 | bits)
STREAM_MAPS = {TPDO2_MAP: [0x20000020, 0x20020020],   # T_sensor_C, current_A
               TPDO3_MAP: [0x28070020, 0x20010020]}   # ident_sample, Q_W
IDENT_STATE_NAMES = {0: "not run", 1: "running", 2: "done", 3: "interrupted"}


@dataclass
class Stream:
    """Samples of the experiment as they arrive: TPDO2 (T, I) then TPDO3 (sample number, Q) of one SYNC."""

    cob_t: int
    cob_q: int
    total: int
    T_C: np.ndarray = field(init=False)
    I_A: np.ndarray = field(init=False)
    Q_W: np.ndarray = field(init=False)
    seen: np.ndarray = field(init=False)
    last: tuple[float, float] | None = None
    count: int = 0
    duplicates: int = 0
    unpaired: int = 0
    highest: int = 0
    cond: threading.Condition = field(default_factory=threading.Condition)

    def __post_init__(self) -> None:
        self.T_C, self.I_A, self.Q_W = (np.full(self.total, np.nan) for _ in range(3))
        self.seen = np.zeros(self.total, dtype=bool)

    def on_frame(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if len(data) != 8:
            return
        if can_id == self.cob_t:
            self.last = struct.unpack("<ff", data)
            return
        k, q = struct.unpack("<If", data)
        pair, self.last = self.last, None
        if k == 0 or k > self.total:
            return   # not (or no longer) in the experiment
        if pair is None:
            self.unpaired += 1
            return
        j = k - 1
        with self.cond:
            if self.seen[j]:
                self.duplicates += 1
            self.T_C[j], self.I_A[j] = pair
            self.Q_W[j] = q
            self.seen[j] = True
            self.count += 1
            self.highest = max(self.highest, k)
            self.cond.notify_all()

    def missing(self) -> int:
        return int(self.total - self.seen.sum())

    def fill(self, j: int, T_C: float, I_A: float, Q_W: float) -> None:
        """Sample ``j`` fetched by SDO (lost on the bus)."""
        with self.cond:
            self.T_C[j], self.I_A[j], self.Q_W[j] = T_C, I_A, Q_W
            self.seen[j] = True


class _Sdo:
    """SDO access by EDS name to one node, with the CLI's one-line failures."""

    def __init__(self, nw, target: common.Target, timeout_s: float) -> None:
        self.t = target
        self.node = common.remote(nw, target, timeout_s)

    def info(self, key):
        return common.lookup(self.t, key)

    def get(self, key) -> Any:
        return common.sdo_read(self.node, self.t, self.info(key))

    def set(self, key, value) -> None:
        info = self.info(key)
        common.check_range(info, value)
        common.sdo_write(self.node, self.t, info, value)

    def raw_get(self, index: int, sub: int) -> int:
        return int(self.get((index, sub)))

    def raw_set(self, index: int, sub: int, value: int) -> None:
        self.set((index, sub), value)


def _parse_amplitude(text: str) -> tuple[float, float]:
    try:
        lo, hi = (float(x) for x in text.split(","))
    except ValueError:
        raise UserError(f"--amplitude-A: expected LO,HI in A (e.g. 0.1,1.0), got {text!r}") from None
    if not (0.0 <= lo <= hi and math.isfinite(hi)):
        raise UserError(f"--amplitude-A: expected 0 <= LO <= HI, A; got {text!r}")
    return lo, hi


def run_live(args: argparse.Namespace) -> int:
    from telethermo.ident import NarmaOrders, UnstableModelError, save_model
    from telethermo.ident.experiment import ExperimentSettings, Record, fit_experiment
    from telethermo.ident.plan import IdentifyPlan

    net = common.network(args)
    target = common.resolve_node(net, args.node)
    try:
        orders = NarmaOrders.parse(args.orders)
    except ValueError as exc:
        raise UserError(f"--orders: {exc}") from None
    lo, hi = _parse_amplitude(args.amplitude_A)
    n_val = args.validation if args.validation is not None else max(args.samples // 2, 1)
    try:
        plan = IdentifyPlan(seed=args.seed, rest_samples=args.rest, train_samples=args.samples,
                            validation_samples=n_val, amplitude_A=(lo, hi), hold_samples=args.hold)
    except ValueError as exc:
        raise UserError(str(exc).replace("IdentifyPlan.", "plan: ")) from None
    if args.samples < 4 * orders.d + 200:
        raise UserError(f"--samples must be at least {4 * orders.d + 200} for orders {args.orders}, got {args.samples}")
    if orders.d > 48:
        raise UserError(f"--orders {args.orders}: {orders.d} parameters; a node holds at most 48 (object 0x2310)")
    for key in ("ident_seed", "ident_rest_samples", "ident_train_samples", "ident_validation_samples",
                "ident_amplitude_min_A", "ident_amplitude_max_A", "ident_hold_samples"):
        common.lookup(target, key)   # an EDS without the identification objects: say so before touching the node
    period_s = net.sync.period_s
    out = None
    if args.out:
        from pathlib import Path
        out = Path(args.out)
        if out.exists() and out.is_dir():
            raise UserError(f"--out {out}: is a directory; expected a file name")

    with common.canopen_network(args, net) as nw:
        hb = common.watch_heartbeats(nw)
        if not hb.wait_for(lambda: target.node_id in hb.last, common.heartbeat_wait_s(net) + 1.0):
            raise common.Failure(f"{target.role} (node {target.node_id}) sends no heartbeat: is it running on this bus?")
        state = hb.state_name(target.node_id)
        if state != "OPERATIONAL":
            raise common.Failure(f"{target.role} (node {target.node_id}) is {state}: identification runs on its SYNC "
                                 f"cycle (start it: telethermo nmt start {target.role})")
        dev = _Sdo(nw, target, args.timeout)
        mode0 = int(dev.get("mode"))
        if mode0 == int(Mode.IDENTIFY):
            raise common.Failure(f"{target.role} is already in identify mode (another identification running?)")
        if int(dev.get("contact")) and not args.force:
            raise common.Failure(f"{target.role}: its pad is touched (contact = 1); identification needs a pad in air "
                                 "(lift the finger or the probe), or --force")
        # the peer: out of telepresence while its partner runs a PRBS
        peer_restore = None
        for t in common.node_targets(net):
            if t.node_id != target.node_id and t.node_id in hb.last:
                try:
                    pdev = _Sdo(nw, t, args.timeout)
                    pmode = int(pdev.get("mode"))
                except (common.Failure, UserError):
                    continue
                if pmode == int(Mode.TELEPRESENCE):
                    pdev.set("mode", int(Mode.IDLE))
                    peer_restore = (pdev, pmode)
                    print(f"{t.role} (node {t.node_id}): telepresence -> idle for the experiment", file=sys.stderr)
        saved: list[tuple[int, int, int]] = []
        stream = None
        try:
            # 2. the plan
            for key, value in (("ident_seed", plan.seed), ("ident_rest_samples", plan.rest_samples),
                               ("ident_train_samples", plan.train_samples),
                               ("ident_validation_samples", plan.validation_samples),
                               ("ident_amplitude_max_A", max(hi, float(dev.get("ident_amplitude_min_A")))),
                               ("ident_amplitude_min_A", lo), ("ident_amplitude_max_A", hi),
                               ("ident_hold_samples", plan.hold_samples)):
                dev.set(key, value)
            # 3. the stream: save, then remap TPDO2 and TPDO3 (CiA 301: invalid while the mapping changes)
            for comm, mp in ((TPDO2_COMM, TPDO2_MAP), (TPDO3_COMM, TPDO3_MAP)):
                n = dev.raw_get(mp, 0)
                saved += [(comm, 1, dev.raw_get(comm, 1)), (comm, 2, dev.raw_get(comm, 2))]
                saved += [(mp, s, dev.raw_get(mp, s)) for s in range(1, n + 1)] + [(mp, 0, n)]
            cobs = {}
            for comm, mp in ((TPDO2_COMM, TPDO2_MAP), (TPDO3_COMM, TPDO3_MAP)):
                cob = dev.raw_get(comm, 1)
                dev.raw_set(comm, 1, cob | PDO_INVALID)
                dev.raw_set(mp, 0, 0)
                for s, entry in enumerate(STREAM_MAPS[mp], start=1):
                    dev.raw_set(mp, s, entry)
                dev.raw_set(mp, 0, len(STREAM_MAPS[mp]))
                dev.raw_set(comm, 2, 1)
                dev.raw_set(comm, 1, cob & ~PDO_INVALID)
                cobs[comm] = cob & 0x7FF
            stream = Stream(cobs[TPDO2_COMM], cobs[TPDO3_COMM], plan.total)
            # only what this command needs from now on (in the kernel on SocketCAN): the stream, SDO
            # responses, heartbeats; a reader that also parsed every SYNC and PDO of a lockstep session falls
            # behind on a slow computer
            nw.bus.set_filters([{"can_id": stream.cob_t, "can_mask": 0x7FF, "extended": False},
                                {"can_id": stream.cob_q, "can_mask": 0x7FF, "extended": False},
                                {"can_id": 0x580, "can_mask": 0x780, "extended": False},
                                {"can_id": 0x700, "can_mask": 0x780, "extended": False}])
            nw.subscribe(stream.cob_t, stream.on_frame)
            nw.subscribe(stream.cob_q, stream.on_frame)
            # 4. run
            print(f"identify {target.role} (node {target.node_id}): {plan.total} samples "
                  f"({plan.rest_samples} rest + {plan.train_samples} training + {plan.validation_samples} held-out, "
                  f"{lo:g}..{hi:g} A, {plan.hold_samples} samples per bit) at {period_s * 1e3:g} ms "
                  f"({plan.total * period_s:.0f} s in real time)", file=sys.stderr)
            t0 = time.perf_counter()
            dev.set("mode", int(Mode.IDENTIFY))
            _wait(stream, dev, plan, period_s, quiet=args.quiet)
            t_exp = time.perf_counter() - t0
        finally:
            nw.bus.set_filters(None)
            _restore(dev, mode0, saved, peer_restore)
            if stream is not None:
                nw.unsubscribe(stream.cob_t)
                nw.unsubscribe(stream.cob_q)
        fetched = _fetch_lost(stream, dev, plan)
        guard = int(dev.get("ident_guard"))
        start_cycle = int(dev.get("ident_start_cycle"))
        if stream.missing() or stream.duplicates:
            raise common.Failure(f"{stream.missing()} of {plan.total} samples missing and {stream.duplicates} repeated on "
                                 "the bus; nothing fitted or loaded: run again")
        # 6. fit
        print("identify: fitting (least squares, output-error refinement, stability check) ...", file=sys.stderr,
              flush=True)
        rec = Record(t_s=np.arange(plan.total) * period_s, current_A=stream.I_A.copy(), T_C=stream.T_C.copy(),
                     Q_W=stream.Q_W.copy(), T_sink_C=np.full(plan.total, np.nan), Q_true_W=np.full(plan.total, np.nan),
                     guard_interventions=guard)
        settings = ExperimentSettings(rest_samples=plan.rest_samples, amplitude_A=plan.amplitude_A,
                                      hold_samples=plan.hold_samples)
        meta = {"rig": "live node", "node": target.role, "node_id": target.node_id, "bus": common.transport(args, net).describe(),
                "start_cycle": start_cycle, "samples_fetched_by_sdo": fetched}
        try:
            tem, rep = fit_experiment(rec, plan=plan, orders=orders, period_s=period_s, settings=settings,
                                      method=args.method, meta=meta, keep_record=bool(args.plot),
                                      source="telethermo identify (live node)")
        except UnstableModelError as exc:
            print(f"telethermo identify: {exc}; no model written or loaded (a longer experiment, --samples 10000 or "
              "more, gives a better-determined model)", file=sys.stderr)
            return EXIT_FAIL
        rep["experiment_wall_s"] = t_exp
        rep["samples_fetched_by_sdo"] = fetched
        if args.save_data:
            from telethermo.ident.experiment import save_record_csv
            path = save_record_csv(args.save_data, rec, plan, comments={**meta, "plan": plan.as_dict(),
                                                                        "guard_interventions": guard})
            print(f"samples written: {path}", file=sys.stderr)
        from telethermo.cli.identify import print_report
        print_report(rep)
        if not rep["stable"]:
            print(f"telethermo identify: model refused ({rep['stability_reason']}); nothing written or loaded",
                  file=sys.stderr)
            return EXIT_FAIL
        if out is not None:
            save_model(out, tem)
            print(f"model written: {out}")
        if args.plot:
            from telethermo.ident.plots import plot_identification
            print(f"plot written: {plot_identification(args.plot, tem, rep)}")
        if args.no_load:
            print(f"{target.role}: model not loaded (--no-load)")
            return EXIT_OK
        crc = load_model_into(dev, tem)
        print(f"model loaded into {target.role} (node {target.node_id}): CRC-32 0x{crc:08X} verified")
    return EXIT_OK


def _fetch_lost(stream: Stream, dev: _Sdo, plan) -> int:
    """Samples lost on the bus (a busy computer's CAN socket overflows; a real bus can drop frames too) fetched
    again by SDO from the node's record of the experiment (0x280B..0x280E). Returns how many; Failure when so
    many are lost (over a fifth) that the stream is not worth patching."""
    lost = np.flatnonzero(~stream.seen)
    if not len(lost):
        return 0
    if len(lost) > max(100, plan.total // 5):
        raise common.Failure(f"{len(lost)} of {plan.total} samples lost on the bus: too many to fetch again by SDO; "
                             "nothing fitted or loaded (a less loaded computer, or real time, helps)")
    print(f"identify: {len(lost)} of {plan.total} samples lost on the bus; fetching them by SDO ...", file=sys.stderr,
          flush=True)
    for j in lost.tolist():
        dev.set("ident_fetch_sample", j)
        stream.fill(j, float(dev.get("ident_fetched_T_sensor_C")), float(dev.get("ident_fetched_current_A")),
                    float(dev.get("ident_fetched_Q_W")))
    return len(lost)


def _wait(stream: Stream, dev: _Sdo, plan, period_s: float, *, quiet: bool) -> None:
    """Until every sample arrived, or the node says the experiment is done (samples lost on the bus are
    fetched afterwards); Failure if the node stops running it or interrupts it."""
    from telethermo.cli.identify import ProgressBar
    bar = None if quiet else ProgressBar("identify: experiment")
    stall_s = max(5.0, 50 * period_s)
    last_n, last_t, last_poll = -1, time.monotonic(), 0.0
    while True:
        with stream.cond:
            stream.cond.wait_for(lambda: stream.highest >= plan.total, 0.2)
            n, top = stream.count, stream.highest
        if bar is not None:
            bar(min(top, plan.total), plan.total)
        if top >= plan.total:
            return
        now = time.monotonic()
        if n != last_n:
            last_n, last_t = n, now
        if now - last_poll > 1.0:
            last_poll = now
            st = int(dev.get("ident_state"))
            if st == 2 and now - last_t > 0.5:
                return   # done, its last frames lost: fetched by SDO
            if st == 3 or (st == 0 and now - last_t > stall_s):
                mode = int(dev.get("mode"))
                raise common.Failure(f"{dev.t.role}: the experiment was interrupted (ident_state "
                                     f"{IDENT_STATE_NAMES.get(st, st)}, mode {mode}) after {top} of {plan.total} samples")
        if now - last_t > stall_s:
            raise common.Failure(f"{dev.t.role}: no identification sample for {stall_s:.0f} s after {top} of {plan.total} "
                                 "(is the SYNC producer running?)")


def _restore(dev: _Sdo, mode0: int, saved: list[tuple[int, int, int]], peer_restore) -> None:
    """The node's mode and PDO parameters, the peer's mode, as they were; each step tried (one failure does not
    leave the rest undone). Problems are reported on stderr."""
    problems = []

    def attempt(what: str, fn, *a) -> None:
        try:
            fn(*a)
        except (common.Failure, UserError) as exc:
            problems.append(f"{what}: {exc}")

    attempt("mode", dev.set, "mode", mode0)
    comms = [(i, s, v) for i, s, v in saved if i in (TPDO2_COMM, TPDO3_COMM)]
    for comm, mp in ((TPDO2_COMM, TPDO2_MAP), (TPDO3_COMM, TPDO3_MAP)):
        cob = next((v for i, s, v in comms if i == comm and s == 1), None)
        if cob is None:
            continue
        attempt("PDO", dev.raw_set, comm, 1, dev.raw_get(comm, 1) | PDO_INVALID)
        attempt("PDO", dev.raw_set, mp, 0, 0)
        entries = [(s, v) for i, s, v in saved if i == mp and s > 0]
        for s, v in entries:
            attempt("PDO", dev.raw_set, mp, s, v)
        n = next((v for i, s, v in saved if i == mp and s == 0), len(entries))
        attempt("PDO", dev.raw_set, mp, 0, n)
        tt = next((v for i, s, v in comms if i == comm and s == 2), None)
        if tt is not None:
            attempt("PDO", dev.raw_set, comm, 2, tt)
        attempt("PDO", dev.raw_set, comm, 1, cob)
    if peer_restore is not None:
        pdev, pmode = peer_restore
        attempt("peer mode", pdev.set, "mode", pmode)
    for p in problems:
        print(f"telethermo identify: could not restore {p} (NMT reset node restores the power-on settings)",
              file=sys.stderr)


def load_model_into(dev: _Sdo, tem) -> int:
    """Write ``tem`` into the node's model objects by SDO, load it (0x230D = 1) and check the node's CRC-32 of
    the model it then runs (0x230F) against the CRC of what was written. Returns the CRC; Failure otherwise."""
    from telethermo.ident import odmodel
    entries = odmodel.model_entries(tem)
    for e in entries:
        dev.set((e.index, e.sub), e.value)
    dev.set("model_command", odmodel.CMD_LOAD)
    want = odmodel.od_crc32(entries)
    deadline = time.monotonic() + 5.0
    while True:   # taken at the node's next SYNC
        status, crc = int(dev.get("model_status")), int(dev.get("model_crc32"))
        if status == odmodel.STATUS_LOADED and crc == want:
            return crc
        if time.monotonic() > deadline:
            raise common.Failure(f"{dev.t.role}: the model was sent but the node runs CRC-32 0x{crc:08X} "
                                 f"(status {odmodel.STATUS_NAMES.get(status, status)}), not 0x{want:08X}")
        time.sleep(0.05)
