"""The monitor's loops: plain line / JSON-line output for scripts, and the curses view."""

from __future__ import annotations

import json
import math
import time
from typing import Any, Callable, Iterable, TextIO

import can

from .events import ERROR, Event
from .replay import Pacer, ReplayError
from .state import Monitor
from .view import CursesView, ViewState, fmt_time


def _clean(obj: Any) -> Any:
    """JSON has no NaN/inf/bytes: make them strings."""
    if isinstance(obj, float) and not math.isfinite(obj):
        return str(obj)
    if isinstance(obj, (bytes, bytearray)):
        return bytes(obj).hex()
    if isinstance(obj, dict):
        return {k: _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    return obj


#: why an interface gives no controller state (python-can's base class answers ACTIVE whatever happens)
NO_STATE = {
    "VirtualBus": "virtual bus: no controller",
    "SocketCanDaemonBus": "socketcand does not forward it",
    "SocketcanBus": "SocketCAN: only from error frames",
}


def bus_state_poller(bus: can.BusABC) -> Callable[[Monitor], None]:
    """A function that copies ``bus.state`` into the monitor, or says why the interface has none."""
    name = type(bus).__name__
    if getattr(type(bus), "state", None) is can.BusABC.__dict__["state"]:
        reason = NO_STATE.get(name, f"{name} does not report it")
        return lambda mon: mon.set_bus_state(None, reason)

    def poll(mon: Monitor) -> None:
        try:
            mon.set_bus_state(bus.state.name)
        except (can.CanError, NotImplementedError, OSError) as exc:
            mon.set_bus_state(None, f"bus.state failed: {exc}")

    return poll


def dumps(obj: dict) -> str:
    return json.dumps(_clean(obj), allow_nan=False, separators=(",", ":"))


def run_lines(
    source: Iterable[can.Message | None],
    mon: Monitor,
    out: TextIO,
    *,
    as_json: bool,
    frames: bool = True,
    status_every_s: float = 1.0,
    max_frames: int | None = None,
    until: Callable[[], bool] | None = None,
    now: Callable[[], float] | None = None,
    poll: Callable[[Monitor], None] | None = None,
) -> int:
    """Print decoded frames (if ``frames``), events and a status line every ``status_every_s`` of bus
    time; a final status at the end. ``source`` yields None when a live bus is idle; ``now`` then
    gives the bus clock for heartbeat timeouts; ``poll`` reads the controller state before each
    status. Returns the number of frames processed."""
    n = 0
    next_status: float | None = None

    def emit_status() -> None:
        if poll is not None:
            poll(mon)
        snap = mon.snapshot()
        out.write(dumps(snap) + "\n" if as_json else _status_line(snap))

    try:
        for msg in source:
            if until is not None and until():
                break
            if msg is None:
                if now is not None:
                    evs = mon.tick(now())
                    for e in evs:
                        out.write(_event_line(e, as_json))
                out.flush()
                continue
            frame, evs = mon.feed(msg)
            n += 1
            if frames:
                out.write(
                    dumps(frame.to_json()) + "\n"
                    if as_json
                    else f"{fmt_time(frame.t_s)} {frame.kind:10s} 0x{frame.cob_id:03X} [{len(frame.data)}] "
                    f"{frame.data.hex(' '):23s} {frame.text}\n"
                )
            for e in evs:
                out.write(_event_line(e, as_json))
            if status_every_s > 0:
                if next_status is None:
                    next_status = frame.t_s + status_every_s
                elif frame.t_s >= next_status:
                    emit_status()
                    next_status = frame.t_s + status_every_s
            if max_frames is not None and n >= max_frames:
                break
    except KeyboardInterrupt:
        emit_status()  # Ctrl-C: the script still gets the final state
        out.flush()
        raise
    emit_status()
    out.flush()
    return n


def _event_line(e: Event, as_json: bool) -> str:
    """One event as a JSON line or a text line."""
    return dumps(e.to_json()) + "\n" if as_json else f"{fmt_time(e.t_s)} {e.severity:5s} {e.text}\n"


def _status_line(snap: dict) -> str:
    """The text status line of a :meth:`Monitor.snapshot`."""
    sy = snap["sync"]
    nodes = "  ".join(f"{x['node']}:{x['name'] or '?'}={x['nmt_state']}" for x in snap["nodes"])
    sync = f"SYNC {sy['period_s'] * 1e3:.2f}±{sy['jitter_s'] * 1e3:.2f} ms" if sy["period_s"] else "SYNC --"
    return (
        f"{fmt_time(snap['t_s'])} STATUS frames/s {snap['frames_per_s']:.0f} load "
        f"{snap['bus_load_pct']:.1f}% {sync} late {snap['late_cycles']} missed {snap['missed_pdos']} "
        f"err {snap['error_frames']} | {nodes}"
        + (f" | controller {ctl['state']}" if (ctl := snap["controller"])["state"] else "")
        + "\n"
    )


def run_curses(
    stdscr,
    source: Iterable[can.Message | None],
    mon: Monitor,
    vs: ViewState,
    *,
    pacer: Pacer | None = None,
    now: Callable[[], float] | None = None,
    refresh_s: float = 0.2,
    until: Callable[[], bool] | None = None,
    poll: Callable[[Monitor], None] | None = None,
) -> int:
    """The live view. ``pacer`` paces a replay (pausing stops it); for a live bus ``now`` gives the
    time for ticks and a pause only freezes the screen. A damaged log ends the replay with the frames
    decoded so far still shown and the error in ``vs.error`` (and the event log). Returns the number of
    frames decoded."""
    view = CursesView(stdscr, vs)
    it = iter(source)
    n = 0
    last_draw = 0.0
    pending: can.Message | None = None
    idle = False  # the live source had nothing to give the last time it was asked
    while True:
        t = time.monotonic()
        if t - last_draw >= refresh_s or vs.done:
            if not view.handle_keys(mon):
                return n
            if poll is not None:
                poll(mon)
            if now is not None and idle:
                mon.tick(now())  # only with no frame waiting: a backlog must not look like silence
            if not vs.paused:
                view.draw(mon)
            elif vs.paused and view.prev and "[PAUSED]" not in view.prev[0]:
                view.draw(mon)
            last_draw = t
        if until is not None and until():
            return n
        if vs.done:
            time.sleep(refresh_s)
            continue
        if pacer is not None and vs.paused:
            time.sleep(min(refresh_s, 0.05))
            pacer.shift(min(refresh_s, 0.05))
            continue
        if pending is None:
            try:
                pending = next(it)
            except StopIteration:
                vs.done = True
                continue
            except (
                ReplayError
            ) as exc:  # a damaged log: keep what was decoded on the screen, say why it stopped
                vs.done, vs.error = True, str(exc)
                mon.log.add([Event(mon.stats.t_last or 0.0, ERROR, "replay_error", None, str(exc))])
                continue
            idle = pending is None
        if pending is not None and pacer is not None:
            wait = pacer.wait_s(pending)
            if wait > 0:
                time.sleep(min(wait, refresh_s / 2))
                continue
        if pending is not None:
            mon.feed(pending)
            n += 1
        pending = None
