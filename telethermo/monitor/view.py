"""The monitor's terminal view: a pure screen renderer and a curses loop around it.

:func:`render_lines` turns the monitor state into the lines of one screen (testable without a
terminal). :class:`CursesView` writes only the lines that changed since the last refresh (and lets
curses' own screen diffing send the minimum), so the view does not flicker. Keys: ``p`` pause /
resume (the monitor keeps decoding; a replay waits), ``f`` filter the event log (text, ``node=N``,
``warn``/``error``; empty clears), ``c`` clear the event and frame logs, ``q`` quit; pages (``m`` main,
``r`` raw frame list, ``l`` frame log, ``e`` event log, ``i`` incident hints, ``?``/``h`` help) and
scrollback (arrows, PgUp/PgDn, Home/End) are listed in :data:`~telethermo.monitor.pages.KEYS`.
"""

from __future__ import annotations

import curses
import datetime as _dt
from dataclasses import dataclass

from .events import ERROR, WARN, Event
from .hints import incident_hints
from .pages import (
    FOOTER,
    page_events,
    page_help,
    page_hints,
    page_log,
    page_raw,
    page_temperatures,
    scroll_window,
)
from .state import Monitor
from .timing import timing_label

#: incident hints shown on the main page (all of them on the hints page)
MAIN_HINTS = 3


def fmt_time(t: float | None) -> str:
    """Bus time for a person: UTC time of day for epoch stamps, seconds otherwise."""
    if t is None:
        return "--"
    if t > 1e9:
        return _dt.datetime.fromtimestamp(t, _dt.timezone.utc).strftime("%H:%M:%S.%f")[:-3]
    return f"{t:10.3f}s"


def _ms(v: float | None, width: int = 5, digits: int = 0) -> str:
    return f"{v * 1e3:{width}.{digits}f}" if v is not None else " " * (width - 2) + "--"


def event_matches(ev: Event, filt: str) -> bool:
    """The filter language: words that must all match; ``node=N``; ``warn`` = WARN or worse."""
    for word in filt.lower().split():
        if word.startswith("node="):
            if str(ev.node) != word[5:]:
                return False
        elif word in ("warn", "warning"):
            if ev.severity not in (WARN, ERROR):
                return False
        elif word == "error":
            if ev.severity != ERROR:
                return False
        elif word not in f"{ev.kind} {ev.severity} {ev.text}".lower():
            return False
    return True


PAGES = ("main", "raw", "log", "events", "hints", "temps", "help")


@dataclass
class ViewState:
    """What the view shows besides the monitor: the source, pause, the filter, the page and how far
    back it is scrolled (lines before the newest; 0 follows new lines)."""

    source: str = ""
    mode: str = "LIVE"
    paused: bool = False
    filter: str = ""
    done: bool = False
    error: str = ""  # why a replay stopped early (a damaged log)
    page: str = "main"
    scroll: int = 0


def status_lines(mon: Monitor, vs: ViewState) -> list[str]:
    """The three header lines: mode and source; rates and SYNC timing; the counters, named, and the
    CAN controller."""
    s = mon.stats
    sync = s.sync_summary()
    flags = ("  [PAUSED]" if vs.paused else "") + ("  [END OF LOG]" if vs.done and not vs.error else "")
    if vs.error:
        flags += f"  [LOG DAMAGED, replay stopped: {vs.error}]"
    per = mon.config.sync_period_s
    timing = timing_label(mon.timing_json()["sync_lockstep"])  # from the bus, not the network file
    nominal = f" (nominal {per * 1e3:.2f}, {timing})" if per else f" (no nominal period, {timing})"
    sync_txt = (
        f"SYNC {sync['period_s'] * 1e3:.2f} ms ±{sync['jitter_s'] * 1e3:.2f} "
        f"[{sync['min_s'] * 1e3:.2f}..{sync['max_s'] * 1e3:.2f}] "
        f"#{s.sync_counter if s.sync_counter is not None else '-'}"
        if sync["period_s"] is not None
        else "SYNC --"
    ) + nominal
    return [
        f"telethermo monitor | {vs.mode}{flags} | {mon.config.bitrate_bps / 1000:g} kbit/s | {vs.source}",
        f"frames/s {s.frames_per_s:7.0f}  load {100 * s.bus_load:5.1f}%  {sync_txt}",
        f"late cycles {s.late_cycles}  missed PDOs {s.missed_pdos}  error frames {s.error_frames}  "
        f"frames {s.frames}  events: {mon.log.counts[WARN]} warnings, {mon.log.counts[ERROR]} errors  |  "
        f"{mon.controller.text()}",
    ]


def _node_lines(mon: Monitor) -> list[str]:
    lines = ["NODE NAME     NMT              HB ms last/min/max  timeout   boot SDO ok/abort  last EMCY"]
    for n, st in sorted(mon.nodes.items()):
        to = st.hb_timeout_s
        tstate = "never" if st.last_hb_t is None else "LOST" if st.hb_lost else "ok"
        to_txt = f"{tstate}({to * 1e3:.0f})" if to else tstate
        emcy = "-"
        if st.last_emcy:
            e = st.last_emcy
            emcy = (
                f"0x{e['code']:04X} {e['code_text'][:30]} reg 0x{e['register']:02X} "
                f"{fmt_time(st.last_emcy_t)}" + ("" if st.emcy_active else " (reset)")
            )
        lines.append(
            f"{n:4d} {st.name[:8]:8s} {st.nmt_state:16s} "
            f"{_ms(st.hb_period_last_s)}/{_ms(st.hb_period_min_s)}/{_ms(st.hb_period_max_s)}  "
            f"{to_txt:9s} {st.boot_ups:4d} {st.sdo_ok:6d}/{st.sdo_aborts:<5d} {emcy}"
        )
    return lines


def _main_body(mon: Monitor, vs: ViewState, room: int) -> list[str]:
    lines = ["", *_node_lines(mon)]
    lines += [
        f"  {mon.nodes[n].name if n in mon.nodes else n} identified {m.text()}"
        for n, m in sorted(mon.material.by_node.items())
        if m.code is not None
    ]
    lines += ["", "PDO"]
    for key, p in sorted(mon.pdos.items()):
        vals = "  ".join(v.text() for v in p.values)
        name = mon.nodes[p.pdef.node].name if p.pdef.node in mon.nodes else ""
        lines.append(
            f"  0x{p.pdef.cob_id:03X} {p.pdef.label:6s} {name[:8]:8s} "
            f"n={p.count:<7d} miss={p.missing:<4d} {vals}"
        )
    lines += ["", "SDO (last transfer per node)"]
    for n, st in sorted(mon.nodes.items()):
        if st.sdo_transfers:
            r = st.sdo_transfers[-1]
            lines.append(f"  {n:3d} {fmt_time(r.transfer.t_end_s)} {r.text()}")
    hints = incident_hints(mon)
    if hints:
        lines += ["", f"CHECK FIRST ({len(hints)}; [i] for all)"] + [f"  - {h}" for h in hints[:MAIN_HINTS]]
    lines.append("")
    match = (lambda e: event_matches(e, vs.filter)) if vs.filter else None
    evs = [e for e in mon.log.events if match is None or match(e)] if vs.filter else mon.log.events
    shown, note = scroll_window(evs, room - len(lines) - 1, vs.scroll)
    head = f"EVENTS (filter: {vs.filter})" if vs.filter else "EVENTS"
    lines.append(head + (f"  {note}" if note else ""))
    lines += [f"  {fmt_time(e.t_s)} {e.severity:5s} {e.text}" for e in shown]
    return lines


def render_lines(mon: Monitor, vs: ViewState, width: int, height: int) -> list[str]:
    """The lines of one screen, each at most ``width`` characters, exactly ``height`` lines."""
    lines = status_lines(mon, vs)
    room = max(0, height - len(lines) - 1)
    if vs.page == "raw":
        lines += page_raw(mon, room, vs.scroll)
    elif vs.page == "log":
        lines += page_log(mon, fmt_time, room, vs.scroll)
    elif vs.page == "events":
        lines += page_events(
            mon,
            fmt_time,
            room,
            vs.scroll,
            (lambda e: event_matches(e, vs.filter)) if vs.filter else None,
            vs.filter,
        )
    elif vs.page == "hints":
        lines += page_hints(incident_hints(mon), room, vs.scroll)
    elif vs.page == "temps":
        lines += page_temperatures(mon, room, vs.scroll, width)
    elif vs.page == "help":
        lines += page_help(room)
    else:
        lines += _main_body(mon, vs, room)
    lines = lines[: max(0, height - 1)]
    lines += [""] * (height - 1 - len(lines))
    lines.append(FOOTER)
    return [ln[:width] for ln in lines]


class CursesView:
    """Draws :func:`render_lines` in a curses window, rewriting only the lines that changed."""

    def __init__(self, stdscr, vs: ViewState) -> None:
        self.curses = curses
        self.scr = stdscr
        self.vs = vs
        self.prev: list[str] = []
        curses.curs_set(0)
        stdscr.nodelay(True)
        stdscr.keypad(True)
        if curses.has_colors():
            curses.start_color()
            curses.use_default_colors()
            curses.init_pair(1, curses.COLOR_YELLOW, -1)
            curses.init_pair(2, curses.COLOR_RED, -1)
            curses.init_pair(3, curses.COLOR_CYAN, -1)

    def _attr(self, row: int, line: str) -> int:
        c = self.curses
        if not c.has_colors():
            return c.A_BOLD if row < 3 else 0
        if row < 3:
            return c.A_BOLD | c.color_pair(3)
        if " ERROR " in line or " LOST" in line:
            return c.color_pair(2)
        if " WARN " in line or line.startswith("  - ") or "BUS-OFF" in line or "ERROR-PASSIVE" in line:
            return c.color_pair(1)
        return 0

    def draw(self, mon: Monitor) -> None:
        h, w = self.scr.getmaxyx()
        lines = render_lines(mon, self.vs, max(1, w - 1), h)
        if len(self.prev) != len(lines):
            self.scr.erase()
            self.prev = [""] * len(lines)
        for row, line in enumerate(lines):
            if line != self.prev[row]:
                try:
                    self.scr.addstr(row, 0, line, self._attr(row, line))
                    self.scr.clrtoeol()
                except self.curses.error:
                    pass  # writing the bottom-right cell; harmless
        self.prev = lines
        self.scr.noutrefresh()
        self.curses.doupdate()

    def prompt(self, label: str) -> str:
        """Read a line at the bottom (blocking, echoed), for the filter."""
        c = self.curses
        h, w = self.scr.getmaxyx()
        self.scr.nodelay(False)
        c.echo()
        c.curs_set(1)
        try:
            self.scr.addstr(h - 1, 0, label[: w - 1])
            self.scr.clrtoeol()
            raw = self.scr.getstr(h - 1, min(len(label), w - 2), 60)
        finally:
            c.noecho()
            c.curs_set(0)
            self.scr.nodelay(True)
            self.prev = []
        return raw.decode("utf-8", "replace").strip()

    def handle_keys(self, mon: Monitor) -> bool:
        """Process pending keys; False when the user asked to quit."""
        while True:
            k = self.scr.getch()
            if k == -1:
                return True
            if not handle_key(self.vs, mon, k, self._page_rows(), self.prompt):
                return False
            if k == self.curses.KEY_RESIZE:
                self.prev = []

    def _page_rows(self) -> int:
        return max(1, self.scr.getmaxyx()[0] - 6)


PAGE_KEYS = {
    "m": "main",
    "r": "raw",
    "l": "log",
    "e": "events",
    "i": "hints",
    "t": "temps",
    "?": "help",
    "h": "help",
}


def handle_key(vs: ViewState, mon: Monitor, k: int, page_rows: int, prompt) -> bool:
    """One key press: page, scroll, pause, filter, clear; False for quit (pure but for ``prompt``,
    the line editor of the filter)."""
    ch = chr(k) if 0 <= k < 256 else ""
    scroll = {
        curses.KEY_UP: 1,
        curses.KEY_DOWN: -1,
        curses.KEY_PPAGE: page_rows,
        curses.KEY_NPAGE: -page_rows,
        ord("k"): 1,
        ord("j"): -1,
    }.get(k)
    if ch in ("q", "Q"):
        return False
    if ch in PAGE_KEYS or (k == 27 and vs.page == "help"):
        new = PAGE_KEYS.get(ch, "main")
        vs.page = "main" if new == vs.page == "help" else new
        vs.scroll = 0
    elif scroll is not None:
        vs.scroll = max(0, vs.scroll + scroll)
    elif k in (curses.KEY_HOME, ord("g")):
        vs.scroll = 10**9  # clamped to the oldest line by the page
    elif k in (curses.KEY_END, ord("G")):
        vs.scroll = 0
    elif ch in ("p", "P", " "):
        vs.paused = not vs.paused
    elif ch in ("f", "F", "/"):
        vs.filter = prompt("filter (text, node=N, warn, error; empty = none): ")
    elif ch in ("c", "C"):
        mon.log.events.clear()
        mon.frames.clear_history()
    return True
