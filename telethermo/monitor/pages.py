"""The monitor view's other pages, pure like :func:`telethermo.monitor.view.render_lines`: the raw
frame list (one row per COB-ID), the frame history and the event log with scrollback, the incident
hints and the help screen. Each returns the body lines; the view adds the header and footer."""
from __future__ import annotations

from itertools import islice
from typing import Callable, Sequence

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
    ("Up/Down  k/j", "scroll one line (back in time / forward)"),
    ("PgUp/PgDn", "scroll one page"),
    ("Home/End  g/G", "oldest / newest (End follows new lines again)"),
    ("p  Space", "pause / resume (a replay waits; a live bus keeps being decoded)"),
    ("f  /", "filter the events: words, node=N, warn, error; empty clears"),
    ("c", "clear the event log and the frame log"),
    ("q", "quit"),
)

FOOTER = "[?] help  [m]ain [r]aw [l]og [e]vents [i]hints  [arrows/PgUp] scroll  [p]ause [f]ilter [q]uit"


def scroll_window(items: Sequence, room: int, scroll: int) -> tuple[list, str]:
    """The ``room`` items ending ``scroll`` items before the newest, and a position note
    ("lines 10-40 of 2000"; empty when everything fits). ``scroll`` is clamped to the history."""
    n = len(items)
    if room <= 0:
        return [], ""
    scroll = max(0, min(scroll, max(0, n - room)))
    end = n - scroll
    start = max(0, end - room)
    note = "" if n <= room else (f"lines {start + 1}-{end} of {n}" + ("" if scroll == 0 else
                                 f", {scroll} newer below (End to follow)"))
    return list(islice(items, start, end)), note


def _ms(v: float | None) -> str:
    return f"{v * 1e3:9.2f}" if v is not None else "       --"


def raw_rows(rows: list[CobRow]) -> list[str]:
    """The raw frame list: one line per COB-ID."""
    out = []
    for r in rows:
        cob = f"{r.cob_id:08X}" if r.extended else f"     {r.cob_id:03X}"
        data = r.data.hex(" ")
        out.append(f"{cob} {r.kind:10s} {r.node if r.node is not None else '-':>4} {r.count:9d} "
                   f"{_ms(r.period_mean_s)} {_ms(r.period_min_s)} {_ms(r.period_max_s)}  "
                   f"[{len(r.data)}] {data:23s}  {r.text}")
    return out


RAW_HEAD = "  COB-ID KIND       NODE     COUNT   mean ms    min ms    max ms  DLC DATA                      DECODED"


def page_raw(mon: Monitor, fmt_time: Callable, room: int, scroll: int) -> list[str]:
    rows, note = scroll_window(raw_rows(mon.frames.sorted_rows()), room - 2, scroll)
    return [f"RAW FRAME LIST ({len(mon.frames.rows)} identifiers){'  ' + note if note else ''}", RAW_HEAD, *rows]


def page_log(mon: Monitor, fmt_time: Callable, room: int, scroll: int) -> list[str]:
    hist = mon.frames.history
    shown, note = scroll_window(hist, room - 1, scroll)
    lines = [f"FRAME LOG (last {hist.maxlen} frames kept){'  ' + note if note else ''}"]
    lines += [f"  {fmt_time(f.t_s)} {f.kind:10s} 0x{f.cob_id:03X} [{len(f.data)}] {f.data.hex(' '):23s} {f.text}"
              for f in shown]
    return lines


def page_events(mon: Monitor, fmt_time: Callable, room: int, scroll: int,
                match: Callable[[Event], bool] | None, filt: str) -> list[str]:
    evs = [e for e in mon.log.events if match is None or match(e)]
    shown, note = scroll_window(evs, room - 1, scroll)
    head = f"EVENT LOG (last {mon.log.events.maxlen} kept{', filter: ' + filt if filt else ''})"
    return [head + ("  " + note if note else "")] + [f"  {fmt_time(e.t_s)} {e.severity:5s} {e.text}" for e in shown]


def page_hints(hints: list[str], room: int, scroll: int) -> list[str]:
    shown, note = scroll_window(hints or ["nothing to check: no incident now"], room - 1, scroll)
    return [f"INCIDENT HINTS (check first){'  ' + note if note else ''}"] + [f"  - {h}" for h in shown]


def page_help(room: int) -> list[str]:
    lines = ["HELP: keys of telethermo monitor", ""]
    lines += [f"  {k:16s} {what}" for k, what in KEYS]
    lines += ["", "Status bar: frames/s and bus load over the last second; SYNC mean period +- jitter (standard",
              "deviation) [min..max] and the counter; late = SYNC intervals over the nominal period (network",
              "file) by more than half a period; missed PDO = synchronous PDOs not seen before the next SYNC;",
              "error frames = CAN error frames received; warnings/errors = events of that severity so far."]
    return lines[:room]
