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
   a record in which the envelope cut the current, or with the pad touched, is refused;
5. fits and validates the models on the record (:func:`telethermo.ident.experiment.fit_experiment`,
   the same as offline), prints the report, refuses an unstable model;
6. loads the model into the node while it still holds 0 A in IDENTIFY (0x2300..0x2311 by SDO, REAL64
   coefficients; 0x230D = 1) and checks the node's CRC-32 of what it runs (0x230F) against the one of
   what was sent;
7. puts back the node's mode, the PDO parameters it changed and the peer's mode (also on Ctrl-C or a
   failure: Ctrl-C waits for this step).
"""
from __future__ import annotations

import argparse
import contextlib
import math
import signal
import struct
import sys
import threading
import time
from typing import Any

import numpy as np

from telethermo.cli import common
from telethermo.cli.main import EXIT_FAIL, EXIT_OK, UserError
from telethermo.control.types import Mode

PDO_INVALID = 1 << 31
#: the identification stream: (communication, mapping) record of TPDO2..4 and their mapping (index << 16 |
#: sub << 8 | bits): the sample number (ident_sample, U32) with one REAL32 value each
STREAM = ((0x1801, 0x1A01, [0x28070020, 0x20000020]),   # ident_sample, T_sensor_C
          (0x1802, 0x1A02, [0x28070020, 0x20020020]),   # ident_sample, current_A
          (0x1803, 0x1A03, [0x28070020, 0x20010020]))   # ident_sample, Q_W
FIELDS = ("T_sensor_C", "current_A", "Q_W")
IDENT_STATE_NAMES = {0: "not run", 1: "running", 2: "done", 3: "interrupted"}


class Stream:
    """The experiment's values as they arrive: each frame carries a sample number and one value (field f of
    :data:`FIELDS`, by COB-ID). A sample is complete when all three fields arrived."""

    def __init__(self, cobs: list[int], total: int) -> None:
        self.field_of = {cob: f for f, cob in enumerate(cobs)}
        self.total = total
        self.values = np.full((3, total), np.nan)
        self.got = np.zeros((3, total), dtype=bool)
        self.count = 0
        self.complete = 0      # samples with all three values
        self.duplicates = 0
        self.highest = 0
        self.cond = threading.Condition()

    @property
    def T_C(self) -> np.ndarray:
        return self.values[0]

    @property
    def I_A(self) -> np.ndarray:
        return self.values[1]

    @property
    def Q_W(self) -> np.ndarray:
        return self.values[2]

    @property
    def seen(self) -> np.ndarray:
        """Samples with all three values."""
        return self.got.all(axis=0)

    def on_frame(self, can_id: int, data: bytearray, timestamp: float) -> None:
        f = self.field_of.get(can_id)
        if f is None or len(data) != 8:
            return
        k, v = struct.unpack("<If", data)
        if not 1 <= k <= self.total:
            return   # not (or no longer) in the experiment
        j = k - 1
        with self.cond:
            repeated = bool(self.got[f, j])
            if repeated:
                self.duplicates += 1
            self.values[f, j] = v
            self.got[f, j] = True
            self.count += 1
            if not repeated and self.got[0, j] and self.got[1, j] and self.got[2, j]:
                self.complete += 1
            self.highest = max(self.highest, k)
            self.cond.notify_all()

    def missing(self) -> int:
        return int(self.total - self.seen.sum())

    def fill(self, j: int, T_C: float, I_A: float, Q_W: float) -> None:
        """Sample ``j`` fetched by SDO (a value of it lost on the bus)."""
        with self.cond:
            self.values[:, j] = (T_C, I_A, Q_W)
            self.got[:, j] = True


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
    """``telethermo identify NODE``; SIGTERM (a kill, a batch system's stop) is handled like Ctrl-C: the node is
    put back before the command ends."""
    if threading.current_thread() is not threading.main_thread():
        return _run_live(args)

    def on_term(signum, frame):
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGTERM, on_term)
    try:
        return _run_live(args)
    finally:
        signal.signal(signal.SIGTERM, old)


def _run_live(args: argparse.Namespace) -> int:
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
        saved: dict[int, dict] = {}       # per TPDO communication record: its parameters before we changed them
        touched: list[int] = []           # the TPDOs this command started to change (restored, and only they)
        peer_restore: list = []
        stream = None
        try:
            # 1. the peer: out of telepresence while its partner runs a PRBS
            for t in common.node_targets(net):
                if t.node_id != target.node_id and t.node_id in hb.last:
                    try:
                        pdev = _Sdo(nw, t, args.timeout)
                        pmode = int(pdev.get("mode"))
                    except (common.Failure, UserError):
                        continue
                    if pmode == int(Mode.TELEPRESENCE):
                        peer_restore.append((pdev, pmode))
                        pdev.set("mode", int(Mode.IDLE))
                        print(f"{t.role} (node {t.node_id}): telepresence -> idle for the experiment", file=sys.stderr)
            # 2. the plan
            for key, value in (("ident_seed", plan.seed), ("ident_rest_samples", plan.rest_samples),
                               ("ident_train_samples", plan.train_samples),
                               ("ident_validation_samples", plan.validation_samples),
                               ("ident_amplitude_max_A", max(hi, float(dev.get("ident_amplitude_min_A")))),
                               ("ident_amplitude_min_A", lo), ("ident_amplitude_max_A", hi),
                               ("ident_hold_samples", plan.hold_samples)):
                dev.set(key, value)
            # 3. the stream: save every TPDO whole first, then remap (CiA 301: invalid while the mapping changes)
            for comm, mp, _ in STREAM:
                n = dev.raw_get(mp, 0)
                saved[comm] = {"map": mp, "cob": dev.raw_get(comm, 1), "type": dev.raw_get(comm, 2), "n": n,
                               "entries": [dev.raw_get(mp, k) for k in range(1, n + 1)]}
            cobs = []
            for comm, mp, entries in STREAM:
                cob = saved[comm]["cob"]
                touched.append(comm)
                dev.raw_set(comm, 1, cob | PDO_INVALID)
                dev.raw_set(mp, 0, 0)
                for k, entry in enumerate(entries, start=1):
                    dev.raw_set(mp, k, entry)
                dev.raw_set(mp, 0, len(entries))
                dev.raw_set(comm, 2, 1)
                dev.raw_set(comm, 1, cob & ~PDO_INVALID)
                cobs.append(cob & 0x7FF)
            stream = Stream(cobs, plan.total)
            # only what this command needs from now on (in the kernel on SocketCAN): the stream, SDO
            # responses, heartbeats; a reader that also parsed every SYNC and PDO of a lockstep session falls
            # behind on a slow computer
            nw.bus.set_filters([{"can_id": c, "can_mask": 0x7FF, "extended": False} for c in cobs] +
                               [{"can_id": 0x580, "can_mask": 0x780, "extended": False},
                                {"can_id": 0x700, "can_mask": 0x780, "extended": False}])
            for c in cobs:
                nw.subscribe(c, stream.on_frame)
            # 4. run
            print(f"identify {target.role} (node {target.node_id}): {plan.total} samples "
                  f"({plan.rest_samples} rest + {plan.train_samples} training + {plan.validation_samples} held-out, "
                  f"{lo:g}..{hi:g} A, {plan.hold_samples} samples per bit) at {period_s * 1e3:g} ms "
                  f"({plan.total * period_s:.0f} s in real time)", file=sys.stderr)
            t0 = time.perf_counter()
            dev.set("mode", int(Mode.IDENTIFY))
            _wait(stream, dev, plan, period_s, quiet=args.quiet)
            t_exp = time.perf_counter() - t0
            nw.bus.set_filters(None)
            fetched = _fetch_lost(stream, dev, plan)
            if stream.missing() or stream.duplicates:
                raise common.Failure(f"{stream.missing()} of {plan.total} samples missing and {stream.duplicates} "
                                     "values repeated on the bus; nothing fitted or loaded: run again")
            guard = int(dev.get("ident_guard"))
            start_cycle = int(dev.get("ident_start_cycle"))
            _check_record(stream, dev, plan, force=args.force)
            # 5. fit (the node holds 0 A in IDENTIFY, its plan done)
            print("identify: fitting (least squares, output-error refinement, stability check) ...", file=sys.stderr,
                  flush=True)
            rec = Record(t_s=np.arange(plan.total) * period_s, current_A=stream.I_A.copy(), T_C=stream.T_C.copy(),
                         Q_W=stream.Q_W.copy(), T_sink_C=np.full(plan.total, np.nan),
                         Q_true_W=np.full(plan.total, np.nan), guard_interventions=guard)
            settings = ExperimentSettings(rest_samples=plan.rest_samples, amplitude_A=plan.amplitude_A,
                                          hold_samples=plan.hold_samples)
            meta = {"rig": "live node", "node": target.role, "node_id": target.node_id,
                    "bus": common.transport(args, net).describe(), "start_cycle": start_cycle,
                    "samples_fetched_by_sdo": fetched}
            try:
                tem, rep = fit_experiment(rec, plan=plan, orders=orders, period_s=period_s, settings=settings,
                                          method=args.method, meta=meta, keep_record=bool(args.plot),
                                          source="telethermo identify (live node)")
            except UnstableModelError as exc:
                print(f"telethermo identify: {exc}; no model written or loaded (a longer experiment, --samples 10000 "
                      "or more, or lower orders give a better-determined model)", file=sys.stderr)
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
            else:
                # 6. load, while the node still holds 0 A in IDENTIFY (its new predictor starts at rest there)
                crc = load_model_into(dev, tem)
                print(f"model loaded into {target.role} (node {target.node_id}): CRC-32 0x{crc:08X} verified")
        finally:
            # 7. put back what this command changed; Ctrl-C waits for it
            with _sigint_deferred():
                try:
                    nw.bus.set_filters(None)
                except Exception:
                    pass
                if stream is not None:
                    for c in stream.field_of:
                        nw.unsubscribe(c)
                _restore(dev, mode0, saved, touched, peer_restore)
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


def _check_record(stream: Stream, dev: "_Sdo", plan, *, force: bool) -> None:
    """Refuse a record the envelope cut or a touch disturbed (Failure): the node's safety state and contact
    now, and the recorded currents against the plan (a planned non-zero current recorded as 0 A is a cut)."""
    st, trip = int(dev.get("safety_state")), int(dev.get("last_trip_code"))
    planned = plan.currents()
    cut = int(np.sum((planned != 0.0) & (stream.I_A == 0.0)))
    if st == 3 or cut:
        raise common.Failure(f"{dev.t.role}: the safety envelope cut the current during the experiment ({cut} samples "
                             f"at 0 A instead of the plan's; safety state {st}, last trip 0x{trip:04X}); nothing fitted "
                             "or loaded (see telethermo status; telethermo fault-reset once the cause is gone)")
    if int(dev.get("contact")) and not force:
        raise common.Failure(f"{dev.t.role}: the pad is touched (contact = 1) at the end of the experiment; its record "
                             "is not of a pad in air: nothing fitted or loaded (or --force)")


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
            stream.cond.wait_for(lambda: stream.complete >= plan.total, 0.2)
            n, top, done = stream.count, stream.highest, stream.complete
        if bar is not None:
            bar(min(top, plan.total), plan.total)
        if done >= plan.total:
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


def _restore(dev: "_Sdo", mode0: int, saved: dict[int, dict], touched: list[int], peer_restore: list) -> None:
    """The node's mode, the TPDOs this command changed (from their saved parameters, never read again) and the
    peer's mode, as they were. Every step is tried, each SDO twice, and a failing one does not stop the rest;
    what could not be put back is said on stderr."""
    problems = []

    def attempt(what: str, fn, *a) -> None:
        for _ in range(2):
            try:
                fn(*a)
                return
            except (common.Failure, UserError) as exc:
                err = exc
        problems.append(f"{what}: {err}")

    attempt(f"{dev.t.role} mode", dev.set, "mode", mode0)
    for comm in touched:
        sv = saved[comm]
        mp = sv["map"]
        attempt(f"TPDO 0x{comm:04X}", dev.raw_set, comm, 1, sv["cob"] | PDO_INVALID)
        attempt(f"TPDO 0x{comm:04X}", dev.raw_set, mp, 0, 0)
        for k, v in enumerate(sv["entries"], start=1):
            attempt(f"TPDO 0x{comm:04X}", dev.raw_set, mp, k, v)
        attempt(f"TPDO 0x{comm:04X}", dev.raw_set, mp, 0, sv["n"])
        attempt(f"TPDO 0x{comm:04X}", dev.raw_set, comm, 2, sv["type"])
        attempt(f"TPDO 0x{comm:04X}", dev.raw_set, comm, 1, sv["cob"])
    for pdev, pmode in peer_restore:
        attempt(f"{pdev.t.role} mode", pdev.set, "mode", pmode)
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
