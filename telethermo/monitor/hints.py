"""Incident hints: for each common CANopen incident the monitor sees, a short "check first" line, as
a lab engineer would say it (canopen-lens gives such advice; these texts are ours). Pure: the current
state of a :class:`~telethermo.monitor.state.Monitor` in, lines out."""

from __future__ import annotations

from .events import WARN
from .health import BUS_OFF, PASSIVE, WARNING
from .state import Monitor

#: SYNC jitter (standard deviation) above this fraction of the nominal period gets a hint
JITTER_FRACTION = 0.10
#: a live bus without frames for this long gets a hint, s
SILENT_S = 3.0

#: bus load above this fraction of the bitrate gets a hint (CiA recommends staying well below 100 %)
LOAD_FRACTION = 0.70

HEARTBEAT_LOST = (
    "heartbeat lost: is the node powered and its program running? then cable, connector, "
    "termination; consumer_ms > producer_ms in network.toml [heartbeat]"
)
UNEXPECTED_BOOT = (
    "unexpected boot-up: the node reset itself; check its supply (brown-out), its log, a watchdog"
)
ERROR_FRAMES = (
    "error frames: check the bitrate on every node, 120 ohm termination at both ends only, "
    "stub length, ground"
)
BUS_OFF_HINT = "controller BUS-OFF: the adapter left the bus; fix wiring/bitrate, then restart the interface"
PASSIVE_HINT = "controller error-passive/warning: many errors seen; check termination, bitrate, a noisy cable"
LOAD_HINT = (
    "bus load {load:.0f}% > {lim:.0f}%: lower PDO rates or set inhibit times (0x1800:03), "
    "or raise the bitrate on every node"
)
JITTER_HINT = (
    "SYNC jitter {jit:.2f} ms ({pct:.0f}% of {per:.2f} ms): CPU load on the SYNC producer; run "
    "it with real-time priority (chrt), avoid USB adapters' latency, check the bus load"
)
LATE_HINT = (
    "{n} late SYNC cycles (period {per:.2f} ms): the SYNC producer misses its period; CPU load, "
    "priority, a slow rig read; in lockstep: the slower node waits for the other's PDOs"
)
PDO_MISSING_HINT = (
    "{n} synchronous PDOs missed: the producer is late or not OPERATIONAL; check its "
    "heartbeat, its CPU load, its TPDO transmission type (0x1800:02)"
)
NO_TRAFFIC = (
    "no frame on the bus for {s:.0f} s: check the bus setting (--bus or -i/-c, CAN_INTERFACE/"
    "CAN_CHANNEL, ~/.canrc, network.toml [bus]), that the nodes run, and the bitrate"
)
SILENT = "no frame for {s:.0f} s since the last one: the nodes stopped, or the adapter lost the bus"
EMCY_CLASS_HINTS = (
    (0xFF00, 0x8100, "EMCY communication: bus errors, overruns or a lost peer; check the bus and heartbeats"),
    (0xFF00, 0x4200, "EMCY device temperature: check the pad's heat sink, fan and the coolant flow"),
    (0xF000, 0x4000, "EMCY temperature: check the sensors and cooling of the node"),
    (0xF000, 0x2000, "EMCY current: check the Peltier wiring and the driver's current limit"),
    (0xF000, 0x3000, "EMCY voltage: check the supply (under/over-voltage)"),
    (0xF000, 0x5000, "EMCY device hardware: check the rig's connection and the driver"),
    (0xF000, 0x6000, "EMCY software: read the node's log; the node may need a reset (NMT reset)"),
    (0xF000, 0x8000, "EMCY monitoring: a watched limit tripped; read the EMCY text and the node's log"),
    (0x0000, 0x0000, "EMCY: read the code text and the node's log"),
)


def emcy_hint(code: int) -> str:
    """The "check first" line for an EMCY error code."""
    for mask, value, text in EMCY_CLASS_HINTS:
        if code & mask == value:
            return text
    return EMCY_CLASS_HINTS[-1][2]


def incident_hints(mon: Monitor) -> list[str]:
    """Hints for what is wrong now (lost heartbeats, active EMCY, controller state, load, SYNC timing)."""
    out: list[str] = []
    now, s = mon.now_s, mon.stats
    if now is not None and mon.first_tick_s is not None:
        if s.t_last is None and now - mon.first_tick_s >= SILENT_S:
            out.append(NO_TRAFFIC.format(s=now - mon.first_tick_s))
        elif s.t_last is not None and now - s.t_last >= SILENT_S:
            out.append(SILENT.format(s=now - s.t_last))
    for n, st in sorted(mon.nodes.items()):
        who = f"node {n}{' ' + st.name if st.name else ''}"
        if st.hb_lost:
            out.append(f"{who}: {HEARTBEAT_LOST}")
        if st.emcy_active and st.last_emcy:
            out.append(f"{who}: {emcy_hint(st.last_emcy['code'])}")
    if any(e.kind == "boot_up" and e.severity == WARN for e in mon.log.events):
        out.append(UNEXPECTED_BOOT)
    health = mon.controller
    if health.state == BUS_OFF:
        out.append(BUS_OFF_HINT)
    elif health.state in (PASSIVE, WARNING):
        out.append(PASSIVE_HINT)
    if s.error_frames:
        out.append(ERROR_FRAMES)
    if s.bus_load > LOAD_FRACTION:
        out.append(LOAD_HINT.format(load=100 * s.bus_load, lim=100 * LOAD_FRACTION))
    per = mon.config.sync_period_s
    sync = s.sync_summary()
    if per and sync["jitter_s"] is not None and sync["jitter_s"] > JITTER_FRACTION * per:
        out.append(
            JITTER_HINT.format(jit=sync["jitter_s"] * 1e3, pct=100 * sync["jitter_s"] / per, per=per * 1e3)
        )
    if per and s.late_cycles:
        out.append(LATE_HINT.format(n=s.late_cycles, per=per * 1e3))
    if s.missed_pdos:
        out.append(PDO_MISSING_HINT.format(n=s.missed_pdos))
    return out
