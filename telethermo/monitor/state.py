"""The monitor's state machine: frames in, per-node state, bus statistics and events out (the records it
keeps, and its settings :class:`~telethermo.monitor.records.MonitorConfig`, are in :mod:`.records`).

:class:`Monitor` is pure in the sense that matters: it never reads a clock or touches a bus. Every
frame brings its own timestamp (:meth:`Monitor.feed`) and the caller says what time it is when no
frame arrives (:meth:`Monitor.tick`, for heartbeat timeouts and rates on a silent bus). The same
object therefore serves a live bus, a replay at recorded speed and a replay as fast as possible.
"""

from __future__ import annotations

from collections import deque
from typing import Any

from telethermo import cia301
from . import decoder as dec
from .busload import message_length_bits
from .events import ERROR, INFO, WARN, Event, EventLog
from .frames import FrameTable
from .health import ControllerHealth, decode_error_frame
from .liveness import EVENT_HOLDOFF_S, heartbeat_timeouts, missed_pdos, on_heartbeat
from .pdo import PdoDef, PdoMap, od_value as _value, od_var as _var, decode_pdo
from .records import STRIP_DT_S, BusStats, MonitorConfig, NodeState, PdoState, SdoRecord
from .sdo import SdoChannel, SdoTransfer
from .material import MaterialSeen
from .timing import TimingSeen

#: frame lengths kept by content (periodic traffic repeats its frames: SYNC counters, heartbeats, flags)
BITS_CACHE = 4096


class Monitor:
    """Decode frames and keep the state of the bus (see the module docstring)."""

    def __init__(self, config: MonitorConfig | None = None) -> None:
        self.config = config or MonitorConfig()
        self.nodes: dict[int, NodeState] = {}
        self.stats = BusStats()
        self.log = EventLog()
        self.frames = FrameTable()
        self.controller = ControllerHealth()
        self.pdo_map = PdoMap({n: info.od for n, info in self.config.nodes.items() if info.od is not None})
        self.pdos: dict[tuple[int, str, int], PdoState] = {}
        self._window: deque[tuple[float, int]] = deque()
        self._window_bits = 0
        self._last_sync_t: float | None = None
        self._late_event_t: float | None = None
        self._late_unreported = 0
        self._sync_cob = cia301.COB_SYNC
        self.timing = TimingSeen()  # lockstep or real time, from what the bus shows (never the network file)
        self.material = MaterialSeen()  # the identified material, its touch and posterior, as seen
        self._bits: dict[tuple, int] = {}
        self._handlers = {k: getattr(self, f"_on_{k.lower()}") for k in dec.KINDS}
        self.first_tick_s: float | None = None  # live: the first tick's time (a replay never ticks), s
        self.now_s: float | None = None  # live: the last tick's time, s
        for n, info in self.config.nodes.items():
            self._node(n).name = info.name
        self._load_heartbeat_config()

    # -- set-up ----------------------------------------------------------------------------------
    def _node(self, n: int) -> NodeState:
        st = self.nodes.get(n)
        if st is None:
            info = self.config.nodes.get(n)
            st = NodeState(n, name=info.name if info else "", sdo=SdoChannel(n))
            st._factor = self.config.heartbeat_timeout_factor
            self.nodes[n] = st
        return st

    def _od(self, n: int | None):
        info = self.config.nodes.get(n) if n is not None else None
        return info.od if info else None

    def _load_heartbeat_config(self) -> None:
        for n, info in self.config.nodes.items():
            if info.od is None:
                continue
            v = _value(info.od, 0x1017, 0)
            if v:
                self._node(n).producer_time_s = v / 1000.0
            # only the entries 0x1016:00 declares: canopen's ODArray makes up any further subindex
            # from the first one's EDS default (which would undo the network file's consumer time)
            for sub in range(1, min(_value(info.od, 0x1016, 0) or 0, 127) + 1):
                self._set_consumer(_value(info.od, 0x1016, sub) or 0)
            v = _value(info.od, 0x1005, 0)
            if v:
                self._sync_cob = v & 0x7FF

    def _set_consumer(self, raw: int) -> None:
        watched, ms = (raw >> 16) & 0x7F, raw & 0xFFFF
        if watched and ms:
            st = self._node(watched)
            t = ms / 1000.0
            st.consumer_time_s = t if st.consumer_time_s is None else min(st.consumer_time_s, t)

    # -- input -----------------------------------------------------------------------------------
    def feed(self, msg) -> tuple[dec.Frame, list[Event]]:
        """Decode one python-can message and update the state; the decoded frame and new events."""
        t = float(msg.timestamp or 0.0)
        data = bytes(msg.data or b"")
        events: list[Event] = []
        self._account(t, msg, data)
        kind, node = dec.classify(
            msg.arbitration_id,
            extended=bool(msg.is_extended_id),
            remote=bool(msg.is_remote_frame),
            error=bool(msg.is_error_frame),
            sync_cob_id=self._sync_cob,
            pdo_cob_ids=self.pdo_map.table,
        )
        frame = dec.Frame(t, msg.arbitration_id, data, kind, node)
        self._handlers[kind](frame, events)
        self.frames.add(frame, bool(msg.is_extended_id))
        events += self._check_timeouts(t)
        self.log.add(events)
        return frame, events

    def tick(self, now_s: float) -> list[Event]:
        """Advance the monitor's idea of time with no frame (live view refresh); new events."""
        if self.first_tick_s is None:
            self.first_tick_s = now_s
        self.now_s = now_s
        events = self._check_timeouts(now_s)
        self._update_rates(now_s)
        self.log.add(events)
        return events

    def set_bus_state(self, name: str | None, reason: str = "") -> None:
        """The interface's controller state (python-can ``BusState`` name), or None and why not."""
        self.controller.from_bus_state(name, reason)

    # -- bookkeeping -----------------------------------------------------------------------------
    def _account(self, t: float, msg, data: bytes) -> None:
        s = self.stats
        key = (msg.arbitration_id, msg.is_extended_id, msg.is_remote_frame, msg.is_error_frame, msg.dlc, data)
        bits = self._bits.get(key)
        if bits is None:
            if len(self._bits) >= BITS_CACHE:
                self._bits.clear()
            bits = self._bits[key] = message_length_bits(msg)
        s.frames += 1
        s.bits += bits
        if s.t_first is None:
            s.t_first = t
        s.t_last = t
        self._window.append((t, bits))
        self._window_bits += bits
        self._update_rates(t)

    def _update_rates(self, now: float) -> None:
        s, w = self.stats, self.config.window_s
        while self._window and self._window[0][0] <= now - w:
            self._window_bits -= self._window.popleft()[1]
        if s.t_first is None:
            return
        span = min(w, max(now - s.t_first, 0.0))
        if span <= 0:
            return
        s.frames_per_s = len(self._window) / span
        s.bus_load = self._window_bits / (self.config.bitrate_bps * span)

    def _check_timeouts(self, now: float) -> list[Event]:
        return heartbeat_timeouts(self.nodes.values(), now)

    # -- per service -----------------------------------------------------------------------------
    def _on_error_frame(self, f: dec.Frame, ev: list[Event]) -> None:
        self.stats.error_frames += 1
        info = decode_error_frame(f.cob_id, f.data)
        before = self.controller.state
        self.controller.from_error_frame(info)
        f.fields = info
        f.text = "error frame: " + (", ".join(info["classes"] + info["controller"]) or "no class bits")
        if info["tx_errors"] is not None:
            f.text += f"; TX errors {info['tx_errors']}, RX errors {info['rx_errors']}"
        ev.append(Event(f.t_s, WARN, "error_frame", None, "CAN " + f.text, {"data": f.data.hex(), **info}))
        if info["state"] is not None and info["state"] != before:
            ev.append(
                Event(
                    f.t_s,
                    ERROR if info["state"] == "BUS-OFF" else WARN,
                    "controller_state",
                    None,
                    f"CAN controller {before or 'unknown'} -> {info['state']}",
                    {"state": info["state"]},
                )
            )

    def _on_unknown(self, f: dec.Frame, ev: list[Event]) -> None:
        self.stats.unknown_frames += 1
        f.text = f"unknown COB-ID 0x{f.cob_id:03X} [{len(f.data)}] {f.data.hex(' ')}"

    def _malformed(self, f: dec.Frame, ev: list[Event], text: str) -> None:
        self.stats.malformed += 1
        ev.append(
            Event(
                f.t_s, WARN, "malformed", f.node, f"{f.kind} 0x{f.cob_id:03X}: {text}", {"data": f.data.hex()}
            )
        )

    def _on_lss(self, f: dec.Frame, ev: list[Event]) -> None:
        f.text = (
            f"LSS {'master' if f.cob_id == cia301.COB_LSS_RX else 'slave'} cs 0x{f.data[:1].hex() or '--'}"
        )

    def _on_nmt(self, f: dec.Frame, ev: list[Event]) -> None:
        f.fields = dec.decode_nmt(f.data)
        if "error" in f.fields:
            f.text = f"NMT {f.fields['error']}"
            self._malformed(f, ev, f.fields["error"])
            return
        target = f.fields["target"]
        f.node = target
        who = "all nodes" if target == 0 else f"node {target}"
        f.text = f"NMT {f.fields['command_name']} -> {who}"
        targets = list(self.nodes) if target == 0 else [target]
        for n in targets:
            st = self._node(n)
            st.nmt_pending = f.fields["target_state"]
            if f.fields["command"] in (0x81, 0x82):
                st.reset_pending = True
                self.pdo_map.reset_node(n)
        for p in self.pdos.values():
            if target in (0, p.pdef.node):
                p.armed = False
        ev.append(Event(f.t_s, INFO, "nmt", target, f.text, dict(f.fields)))

    def _on_sync(self, f: dec.Frame, ev: list[Event]) -> None:
        f.fields = dec.decode_sync(f.data)
        s = self.stats
        s.syncs += 1
        c = f.fields["counter"]
        f.text = "SYNC" + (f" #{c}" if c is not None else "")
        if "error" in f.fields:
            self._malformed(f, ev, f.fields["error"])
        if c is not None and s.sync_counter is not None and c != s.sync_counter + 1 and c != 1:
            s.sync_counter_errors += 1
            ev.append(
                Event(
                    f.t_s,
                    WARN,
                    "sync_counter",
                    None,
                    f"SYNC counter jumped {s.sync_counter} -> {c}",
                    {"previous": s.sync_counter, "counter": c},
                )
            )
        s.sync_counter = c
        if self._last_sync_t is not None:
            dt = f.t_s - self._last_sync_t
            s.sync_intervals_s.append(dt)
            f.fields["interval_s"] = dt
            per = self.config.sync_period_s
            if per and dt > per * (1.0 + self.config.late_tolerance):
                s.late_cycles += 1
                self._late_unreported += 1
                # every late cycle is counted; the log gets at most one event per second of bus time
                if self._late_event_t is None or f.t_s - self._late_event_t >= EVENT_HOLDOFF_S:
                    n = self._late_unreported
                    ev.append(
                        Event(
                            f.t_s,
                            WARN,
                            "late_cycle",
                            None,
                            f"late cycle: SYNC after {dt * 1e3:.2f} ms (period {per * 1e3:.2f} ms)"
                            + (f"; {n} late cycles since the last report" if n > 1 else ""),
                            {"interval_s": dt, "period_s": per, "late_since_last_event": n},
                        )
                    )
                    self._late_event_t, self._late_unreported = f.t_s, 0
        self._last_sync_t = f.t_s
        # PDOs on every SYNC (transmission type 1) from OPERATIONAL nodes must have come in between
        ev += missed_pdos(self.pdos.values(), f.t_s, s)
        for pdef in self.pdo_map.table.values():
            if pdef.direction == "TPDO" and pdef.valid and pdef.transmission_type == 1:
                st = self.nodes.get(pdef.node)
                if (
                    st is not None
                    and st.nmt_state == "OPERATIONAL"
                    and st.nmt_pending is None
                    and not st.hb_lost
                ):
                    self._pdo_state(pdef).armed = True

    def _pdo_state(self, pdef: PdoDef) -> PdoState:
        key = (pdef.node, pdef.direction, pdef.number)
        p = self.pdos.get(key)
        if p is None or p.pdef != pdef:
            old = p
            p = PdoState(pdef)
            if old is not None:
                p.count, p.missing = old.count, old.missing
            self.pdos[key] = p
        return p

    def _on_emcy(self, f: dec.Frame, ev: list[Event]) -> None:
        f.fields = dec.decode_emcy(f.data)
        f.text = dec.describe_emcy(f.fields)
        if "code" not in f.fields:
            self._malformed(f, ev, f.fields["error"])
            return
        st = self._node(f.node)
        st.emcys += 1
        st.error_register = f.fields["register"]
        st.emcy_active = not f.fields["reset"]
        if not f.fields["reset"]:
            st.last_emcy, st.last_emcy_t = dict(f.fields), f.t_s
        if f.fields["reset"]:
            ev.append(Event(f.t_s, INFO, "emcy_reset", f.node, f"node {f.node}: {f.text}", dict(f.fields)))
        else:
            ev.append(Event(f.t_s, ERROR, "emcy", f.node, f"node {f.node}: {f.text}", dict(f.fields)))

    def _on_time(self, f: dec.Frame, ev: list[Event]) -> None:
        f.fields = dec.decode_time(f.data)
        if "error" in f.fields:
            f.text = f"TIME {f.fields['error']}"
            self._malformed(f, ev, f.fields["error"])
        else:
            f.text = f"TIME {f.fields['iso']}"

    def _on_node_guard(self, f: dec.Frame, ev: list[Event]) -> None:
        f.text = f"node guarding request -> node {f.node}"

    def _on_heartbeat(self, f: dec.Frame, ev: list[Event]) -> None:
        f.fields = dec.decode_heartbeat(f.data)
        if "error" in f.fields:
            f.text = f"heartbeat {f.fields['error']}"
            self._malformed(f, ev, f.fields["error"])
            return
        on_heartbeat(self._node(f.node), f, ev)
        if f.fields["boot_up"]:
            self.pdo_map.reset_node(f.node)

    def _on_pdo(self, f: dec.Frame, ev: list[Event]) -> None:
        pdef = self.pdo_map.lookup(f.cob_id)
        if pdef is None:
            base = f.cob_id & 0x780
            label = (
                f"TPDO{cia301.DEFAULT_TPDO_BASE.index(base) + 1}"
                if base in cia301.DEFAULT_TPDO_BASE
                else f"RPDO{cia301.DEFAULT_RPDO_BASE.index(base) + 1}"
                if base in cia301.DEFAULT_RPDO_BASE
                else "PDO"
            )
            f.fields = {"mapping": None, "guess": label}
            f.text = (
                f"{label}? node {f.node} (no mapping known: --eds NODE=FILE, or --rig-config for an I/O "
                f"module) {f.data.hex(' ')}"
            )
            return
        f.node = pdef.node
        values, err = decode_pdo(pdef, f.data)
        st = self._node(pdef.node)
        st.pdo_frames[pdef.label] = st.pdo_frames.get(pdef.label, 0) + 1
        p = self._pdo_state(pdef)
        p.count += 1
        p.last_t = f.t_s
        p.values = values
        for v in values:
            self._observe_value(pdef.node, v.name, v.value, pdef.label)
        if p.trace_t is None or f.t_s - p.trace_t >= 0.99 * STRIP_DT_S:  # 1 %: float bus times
            p.trace.append((f.t_s, tuple(v.value for v in values)))
            p.trace_t = f.t_s
        p.armed = False
        p.missing_streak = 0
        f.fields = {
            "pdo": pdef.label,
            "producer" if pdef.direction == "TPDO" else "consumer": pdef.node,
            "values": [v.to_json() for v in values],
        }
        f.text = f"{pdef.label} node {pdef.node}: " + ", ".join(v.text() for v in values)
        if err:
            f.fields["error"] = err
            ev.append(Event(f.t_s, WARN, "pdo_length", pdef.node, err, {"cob_id": f.cob_id}))

    def _on_sdo_req(self, f: dec.Frame, ev: list[Event]) -> None:
        self._sdo(f, ev, client=True)

    def _on_sdo_resp(self, f: dec.Frame, ev: list[Event]) -> None:
        self._sdo(f, ev, client=False)

    def _sdo(self, f: dec.Frame, ev: list[Event], *, client: bool) -> None:
        st = self._node(f.node)
        step = st.sdo.request(f.t_s, f.data) if client else st.sdo.response(f.t_s, f.data)
        f.text = f"SDO {'req' if client else 'resp'} node {f.node}: {step.text}"
        f.fields = {"step": step.text}
        if step.done is not None:
            rec = self._record(step.done)
            f.text += f" | {rec.text()}"
            st.sdo_transfers.append(rec)
            f.fields["transfer"] = rec.to_json()
            tr = step.done
            if tr.status == "ok":
                st.sdo_ok += 1
                self._observe_value(f.node, rec.name, rec.value, "SDO")
                self._observe_config(f, tr, ev)
            elif tr.status == "aborted":
                st.sdo_aborts += 1
                ev.append(
                    Event(f.t_s, WARN, "sdo_abort", f.node, f"node {f.node} SDO {rec.text()}", rec.to_json())
                )
            else:
                ev.append(
                    Event(f.t_s, WARN, "sdo_error", f.node, f"node {f.node} SDO {rec.text()}", rec.to_json())
                )
        elif step.problem:
            ev.append(Event(f.t_s, WARN, "sdo_error", f.node, f"node {f.node} SDO {step.problem}", {}))

    def _record(self, tr: SdoTransfer) -> SdoRecord:
        var = _var(self._od(tr.node), tr.index, tr.subindex) if self._od(tr.node) is not None else None
        name, unit, value = "", "", tr.data
        if var is not None:
            name, unit = var.qualname, var.unit or ""
            if tr.status == "ok":
                try:
                    value = var.decode_raw(tr.data)
                except Exception:  # a length mismatch is shown as raw bytes, never a crash
                    value = tr.data
        return SdoRecord(tr, name, value, unit)

    def _observe_value(self, node: int | None, name: str, value: Any, how: str) -> None:
        """An object value seen on the bus (``how``: "SDO" or the PDO's label), for timing and material."""
        self.timing.observe(node, name, value, how)
        self.material.observe(node, name, value, how)

    def _observe_config(self, f: dec.Frame, tr: SdoTransfer, ev: list[Event]) -> None:
        change = self.pdo_map.observe_sdo(tr.node, tr.index, tr.subindex, tr.data)
        if change:
            ev.append(
                Event(
                    f.t_s,
                    INFO,
                    "pdo_remap",
                    tr.node,
                    change,
                    {"index": tr.index, "subindex": tr.subindex, "data": tr.data.hex()},
                )
            )
        if tr.direction != "download" or not tr.data:
            return
        raw = int.from_bytes(tr.data[:4], "little")
        if tr.index == 0x1017 and tr.subindex == 0:
            self._node(tr.node).producer_time_s = raw / 1000.0 if raw else None
        elif tr.index == 0x1016 and tr.subindex >= 1:
            self._set_consumer(raw)
        elif tr.index == 0x1005 and tr.subindex == 0 and raw:
            self._sync_cob = raw & 0x7FF

    # -- output ----------------------------------------------------------------------------------
    def timing_json(self) -> dict[str, Any]:
        """The pair's timing as the bus shows it (:mod:`.timing`), and what the network file says."""
        lockstep, why = self.timing.verdict(self.stats.sync_intervals_s, self.config.sync_period_s)
        return {
            "sync_lockstep": lockstep,
            "sync_timing_evidence": why,
            "network_file_lockstep": self.config.sync_lockstep,
        }

    def snapshot(self) -> dict[str, Any]:
        """The whole state as JSON-able data (for --json and tests)."""
        s = self.stats
        return {
            "type": "status",
            "t_s": s.t_last,
            "frames": s.frames,
            "frames_per_s": s.frames_per_s,
            "bus_load_pct": 100.0 * s.bus_load,
            "bitrate_bps": self.config.bitrate_bps,
            "error_frames": s.error_frames,
            "unknown_frames": s.unknown_frames,
            "malformed": s.malformed,
            "syncs": s.syncs,
            "sync_counter": s.sync_counter,
            "sync_counter_errors": s.sync_counter_errors,
            "sync": s.sync_summary(),
            "sync_period_nominal_s": self.config.sync_period_s,
            **self.timing_json(),
            "late_cycles": s.late_cycles,
            "missed_pdos": s.missed_pdos,
            "materials": self.material.to_json(),
            "events": dict(self.log.counts),
            "controller": self.controller.to_json(),
            "cob_ids": [r.to_json() for r in self.frames.sorted_rows()],
            "nodes": [st.to_json() for _, st in sorted(self.nodes.items())],
            "pdos": [
                {
                    "node": p.pdef.node,
                    "pdo": p.pdef.label,
                    "cob_id": p.pdef.cob_id,
                    "count": p.count,
                    "missing": p.missing,
                    "values": [v.to_json() for v in p.values],
                }
                for _, p in sorted(self.pdos.items())
            ],
        }
