"""A node's liveness as the monitor sees it: heartbeats (boot-up, NMT state, period), their loss against
the consumer time or the timeout (:attr:`~telethermo.monitor.records.NodeState.hb_timeout_s`), and the
PDOs a SYNC expected that did not come."""

from __future__ import annotations

from typing import Iterable

from telethermo import cia301

from . import decoder as dec
from .events import ERROR, INFO, WARN, Event
from .records import BusStats, NodeState, PdoState

#: a repeated WARN of the same kind (late cycle, missing PDO) is logged at most once per this bus time, s
EVENT_HOLDOFF_S = 1.0


def on_heartbeat(st: NodeState, f: dec.Frame, ev: list[Event]) -> None:
    """Update ``st`` for the decoded heartbeat ``f`` (bus time ``f.t_s``, s) and add its events to ``ev``."""
    new = f.fields["state_name"]
    f.text = f"{'boot-up' if f.fields['boot_up'] else 'heartbeat ' + new} node {f.node}"
    st.heartbeats += 1
    if f.fields["boot_up"]:
        st.boot_ups += 1
        if st.nmt_state == cia301.NMT_UNKNOWN or st.reset_pending:
            ev.append(
                Event(f.t_s, INFO, "boot_up", f.node, f"node {f.node} {st.name}: boot-up".replace(" :", ":"))
            )
        else:
            ev.append(
                Event(
                    f.t_s,
                    WARN,
                    "boot_up",
                    f.node,
                    f"node {f.node} {st.name}: unexpected boot-up (was {st.nmt_state})".replace(" :", ":"),
                )
            )
        st.reset_pending = False
        st.after_boot = True  # boot-up -> first heartbeat is not a heartbeat period
    elif st.last_hb_t is not None and not st.after_boot:
        dt = f.t_s - st.last_hb_t
        st.hb_period_last_s = dt
        st.hb_period_min_s = dt if st.hb_period_min_s is None else min(st.hb_period_min_s, dt)
        st.hb_period_max_s = dt if st.hb_period_max_s is None else max(st.hb_period_max_s, dt)
    else:
        st.after_boot = False
    if st.hb_lost:
        st.hb_lost = False
        ev.append(
            Event(
                f.t_s,
                INFO,
                "heartbeat_back",
                f.node,
                f"node {f.node} {st.name}: heartbeat back".replace(" :", ":"),
            )
        )
    if new != st.nmt_state and not f.fields["boot_up"]:
        ev.append(
            Event(
                f.t_s,
                INFO,
                "nmt_state",
                f.node,
                f"node {f.node} {st.name}: {st.nmt_state} -> {new}".replace(" :", ":"),
                {"from": st.nmt_state, "to": new},
            )
        )
    st.nmt_state = new
    st.last_hb_t = f.t_s
    st.nmt_pending = None


def heartbeat_timeouts(nodes: Iterable[NodeState], now: float) -> list[Event]:
    """Mark the nodes whose heartbeat is overdue at bus time ``now`` (s) lost; one event each."""
    out = []
    for st in nodes:
        to = st.hb_timeout_s
        if st.last_hb_t is None or to is None or st.hb_lost:
            continue
        if now - st.last_hb_t > to:
            st.hb_lost = True
            st.hb_losses += 1
            out.append(
                Event(
                    now,
                    ERROR,
                    "heartbeat_lost",
                    st.node,
                    f"node {st.node} {st.name}: heartbeat lost (none for {(now - st.last_hb_t) * 1e3:.1f} ms "
                    f"> {st.hb_timeout_from} {to * 1e3:.0f} ms)".replace(" :", ":"),
                    {"silence_s": now - st.last_hb_t, "timeout_s": to},
                )
            )
    return out


def missed_pdos(pdos: Iterable[PdoState], t_s: float, stats: BusStats) -> list[Event]:
    """At a SYNC (bus time ``t_s``, s): count the PDOs armed at the previous SYNC that did not come
    (per PDO and in ``stats``), disarm all; at most one event per PDO and second of bus time."""
    out: list[Event] = []
    for p in pdos:
        if p.armed:
            p.missing += 1
            p.missing_streak += 1
            stats.missed_pdos += 1
            p.unreported += 1
            if p.missing_streak == 1 and (p.event_t is None or t_s - p.event_t >= EVENT_HOLDOFF_S):
                n = p.unreported
                out.append(
                    Event(
                        t_s,
                        WARN,
                        "pdo_missing",
                        p.pdef.node,
                        f"node {p.pdef.node} {p.pdef.label} (0x{p.pdef.cob_id:03X}) "
                        "not seen before the next SYNC (late or lost)"
                        + (f"; {n} cycles since the last report" if n > 1 else ""),
                        {"cob_id": p.pdef.cob_id, "missing_since_last_event": n},
                    )
                )
                p.event_t, p.unreported = t_s, 0
        p.armed = False
    return out
