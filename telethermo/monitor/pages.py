"""The monitor view's other pages, pure like :func:`telethermo.monitor.view.render_lines`: the raw
frame list (one row per COB-ID), the frame history and the event log with scrollback, the incident
hints and the help screen. Each returns the body lines; the view adds the header and footer."""

from __future__ import annotations

import math
from itertools import islice
from typing import Callable, Sequence

from telethermo.units import spellings

from .events import Event
from .frames import CobRow
from .state import Monitor

#: the keys, as the help page and the footer show them
KEYS = (
    ("?  h", "this help (any page key or Esc leaves it)"),
    ("m", "main page: nodes, PDOs, SDO, hints, events"),
    ("r", "raw frame list: one row per COB-ID with count, period, last data"),
    ("l", "frame log: the last decoded frames, scrollable"),
    ("e", "event log: every event kept, scrollable"),
    ("i", "incident hints: what to check first for what is wrong now"),
    ("t", "temperatures: strip chart of every temperature the PDOs carry"),
    ("Up/Down  k/j", "scroll one line (back in time / forward)"),
    ("PgUp/PgDn", "scroll one page"),
    ("Home/End  g/G", "oldest / newest (End follows new lines again)"),
    ("p  Space", "pause / resume (a replay waits; a live bus keeps being decoded)"),
    ("f  /", "filter the events: words, node=N, warn, error; empty clears"),
    ("c", "clear the event log and the frame log"),
    ("q", "quit"),
)

FOOTER = (
    "[?] help  [m]ain [r]aw [l]og [e]vents [i]hints [t]emps  [arrows/PgUp] scroll  [p]ause [f]ilter [q]uit"
)


def scroll_window(items: Sequence, room: int, scroll: int) -> tuple[list, str]:
    """The ``room`` items ending ``scroll`` items before the newest, and a position note
    ("lines 10-40 of 2000"; empty when everything fits). ``scroll`` is clamped to the history."""
    n = len(items)
    if room <= 0:
        return [], ""
    scroll = max(0, min(scroll, max(0, n - room)))
    end = n - scroll
    start = max(0, end - room)
    note = (
        ""
        if n <= room
        else (
            f"lines {start + 1}-{end} of {n}"
            + ("" if scroll == 0 else f", {scroll} newer below (End to follow)")
        )
    )
    return list(islice(items, start, end)), note


def _ms(v: float | None) -> str:
    return f"{v * 1e3:9.2f}" if v is not None else "       --"


def raw_rows(rows: list[CobRow]) -> list[str]:
    """The raw frame list: one line per COB-ID."""
    out = []
    for r in rows:
        cob = f"{r.cob_id:08X}" if r.extended else f"     {r.cob_id:03X}"
        data = r.data.hex(" ")
        out.append(
            f"{cob} {r.kind:10s} {r.node if r.node is not None else '-':>4} {r.count:9d} "
            f"{_ms(r.period_mean_s)} {_ms(r.period_min_s)} {_ms(r.period_max_s)}  "
            f"[{len(r.data)}] {data:23s}  {r.text}"
        )
    return out


RAW_HEAD = (
    "  COB-ID KIND       NODE     COUNT   mean ms    min ms    max ms  DLC DATA                      DECODED"
)


def page_raw(mon: Monitor, room: int, scroll: int) -> list[str]:
    rows, note = scroll_window(raw_rows(mon.frames.sorted_rows()), room - 2, scroll)
    return [
        f"RAW FRAME LIST ({len(mon.frames.rows)} identifiers){'  ' + note if note else ''}",
        RAW_HEAD,
        *rows,
    ]


def page_log(mon: Monitor, fmt_time: Callable, room: int, scroll: int) -> list[str]:
    hist = mon.frames.history
    shown, note = scroll_window(hist, room - 1, scroll)
    lines = [f"FRAME LOG (last {hist.maxlen} frames kept){'  ' + note if note else ''}"]
    lines += [
        f"  {fmt_time(f.t_s)} {f.kind:10s} 0x{f.cob_id:03X} [{len(f.data)}] {f.data.hex(' '):23s} {f.text}"
        for f in shown
    ]
    return lines


def page_events(
    mon: Monitor, fmt_time: Callable, room: int, scroll: int, match: Callable[[Event], bool] | None, filt: str
) -> list[str]:
    evs = [e for e in mon.log.events if match is None or match(e)]
    shown, note = scroll_window(evs, room - 1, scroll)
    head = f"EVENT LOG (last {mon.log.events.maxlen} kept{', filter: ' + filt if filt else ''})"
    return [head + ("  " + note if note else "")] + [
        f"  {fmt_time(e.t_s)} {e.severity:5s} {e.text}" for e in shown
    ]


def page_hints(hints: list[str], room: int, scroll: int) -> list[str]:
    shown, note = scroll_window(hints or ["nothing to check: no incident now"], room - 1, scroll)
    return [f"INCIDENT HINTS (check first){'  ' + note if note else ''}"] + [f"  - {h}" for h in shown]


def page_help(room: int) -> list[str]:
    lines = ["HELP: keys of telethermo monitor", ""]
    lines += [f"  {k:16s} {what}" for k, what in KEYS]
    lines += [
        "",
        "Status bar: frames/s and bus load over the last second; SYNC mean period +- jitter (standard",
        "deviation) [min..max] and the counter; late = SYNC intervals over the nominal period (network",
        "file) by more than half a period; missed PDO = synchronous PDOs not seen before the next SYNC;",
        "error frames = CAN error frames received; warnings/errors = events of that severity so far.",
    ]
    return lines[:room]


#: rows of one signal's strip chart
STRIP_ROWS = 4
#: the spellings of the temperature unit a PDO value may carry (not the bare "C" of a foreign EDS)
TEMPERATURE_UNITS = tuple(s for s in spellings("degC") if s != "C")


def strip_chart(values: list[float], width: int, rows: int = STRIP_ROWS) -> list[str]:
    """An ASCII strip chart of ``values`` (oldest left), the last ``width`` of them, ``rows`` high, scaled
    to their own min..max; NaN and inf leave a gap."""
    vals = values[-width:]
    finite = [v for v in vals if math.isfinite(v)]
    if not finite:
        return [" " * len(vals)] * rows
    lo, hi = min(finite), max(finite)
    span = hi - lo or 1.0
    grid = [[" "] * len(vals) for _ in range(rows)]
    for x, v in enumerate(vals):
        if math.isfinite(v):
            level = round((v - lo) / span * (rows - 1))
            grid[rows - 1 - level][x] = "*"
    return ["".join(r) for r in grid]


def page_temperatures(mon: Monitor, room: int, scroll: int, width: int) -> list[str]:
    """The strip chart of every temperature a PDO carries (unit degC), sampled every 0.1 s of bus time."""
    lines: list[str] = []
    for _, p in sorted(mon.pdos.items()):
        name = mon.nodes[p.pdef.node].name if p.pdef.node in mon.nodes else f"node {p.pdef.node}"
        for i, v in enumerate(p.values):
            if v.unit not in TEMPERATURE_UNITS:
                continue
            series = [
                float(vals[i]) for _, vals in p.trace if i < len(vals) and isinstance(vals[i], (int, float))
            ]
            finite = [x for x in series if math.isfinite(x)]
            rng = f"{min(finite):.3f}..{max(finite):.3f} degC" if finite else "no value"
            lines.append(
                f"  {name} {p.pdef.label} {v.name} = {v.value:.3f} degC   [{rng}, last "
                f"{len(series) * 0.1:.0f} s]"
                if isinstance(v.value, float)
                else f"  {name} {v.name}"
            )
            chart = strip_chart(series, max(10, width - 14))
            hi = f"{max(finite):9.3f} " if finite else " " * 10
            lo = f"{min(finite):9.3f} " if finite else " " * 10
            lines += [
                (hi if k == 0 else lo if k == len(chart) - 1 else " " * 10) + "|" + row
                for k, row in enumerate(chart)
            ]
    shown, note = scroll_window(lines or ["  no temperature PDO seen yet"], room - 1, scroll)
    return [
        f"TEMPERATURES (strip chart, one sample per 0.1 s of bus time){'  ' + note if note else ''}",
        *shown,
    ]
