"""The screen renderer, the JSON-line output and the replay pacing (with an injected clock)."""

from __future__ import annotations

import io
import json
import struct

import can
import pytest

from telethermo.monitor.events import Event
from telethermo.monitor.replay import Pacer, ReplayError, paced, read_log
from telethermo.monitor.run import run_lines
from telethermo.monitor.state import Monitor
from telethermo.monitor.view import ViewState, event_matches, render_lines

from .conftest import monitor_config


def msg(t, cob, data=b""):
    return can.Message(timestamp=t, arbitration_id=cob, data=bytes(data), is_extended_id=False)


def busy_monitor() -> Monitor:
    mon = Monitor(monitor_config(sync_period_s=0.01))
    for m in [
        msg(0.0, 0x701, [0x05]),
        msg(0.0, 0x702, [0x7F]),
        msg(0.01, 0x080, [1]),
        msg(0.011, 0x181, struct.pack("<ff", 33.5, -0.25)),
        msg(0.02, 0x082, struct.pack("<HB5s", 0x4210, 0x09, b"\x00" * 5)),
        msg(0.03, 0x601, struct.pack("<BHBf", 0x23, 0x2200, 0, 25.0)),
        msg(0.031, 0x581, struct.pack("<BHBL", 0x80, 0x2200, 0, 0x06090031)),
    ]:
        mon.feed(m)
    return mon


def test_screen_shows_nodes_pdos_sdo_events_and_fits_the_terminal():
    mon = busy_monitor()
    lines = render_lines(mon, ViewState(source="virtual:x"), 120, 30)
    assert len(lines) == 30 and all(len(ln) <= 120 for ln in lines)
    text = "\n".join(lines)
    assert "   1 master   OPERATIONAL" in text and "   2 slave    PRE-OPERATIONAL" in text
    assert "estimate_C=33.500 degC" in text and "Q_W=-0.250 W" in text
    assert "0x4210 Device temperature reg 0x09" in text
    assert "ABORT 0x06090031 Value of parameter written too high" in text
    assert lines[-1].startswith("[?] help")
    small = render_lines(mon, ViewState(), 40, 8)
    assert len(small) == 8 and all(len(ln) <= 40 for ln in small)


def test_filter_language():
    ev = Event(1.0, "WARN", "sdo_abort", 2, "node 2 SDO write 0x2200:00 kp ABORT")
    assert event_matches(ev, "node=2 abort") and event_matches(ev, "warn")
    assert not event_matches(ev, "node=1") and not event_matches(ev, "error")
    mon = busy_monitor()
    text = "\n".join(render_lines(mon, ViewState(filter="error"), 120, 40))
    assert "EMCY 0x4210" in text and "ABORT 0x06090031" not in text.split("EVENTS")[1]


def test_json_lines_are_valid_json_with_frames_events_and_final_status():
    mon = Monitor(monitor_config())
    out = io.StringIO()
    msgs = [
        msg(0.0, 0x701, [0x05]),
        msg(0.5, 0x181, struct.pack("<ff", float("nan"), 1.0)),
        msg(1.2, 0x080, [1]),
    ]
    n = run_lines(msgs, mon, out, as_json=True, status_every_s=1.0)
    rows = [json.loads(ln) for ln in out.getvalue().splitlines()]
    assert n == 3
    assert [r["type"] for r in rows] == ["frame", "event", "frame", "event", "frame", "status", "status"]
    assert rows[3]["kind"] == "heartbeat_lost"  # 0.5 s of silence > the 250 ms consumer time
    assert rows[2]["fields"]["values"][0]["value"] == "NaN"  # no bare NaN in JSON
    assert rows[-1]["nodes"][0]["nmt_state"] == "OPERATIONAL"


def test_pacer_keeps_the_recorded_spacing_without_drift():
    now = [100.0]
    slept = []

    def sleep(dt):
        slept.append(dt)
        now[0] += dt + 0.002  # every sleep overshoots by 2 ms

    msgs = [msg(t, 0x080) for t in (5.0, 5.1, 5.3, 5.3, 5.6)]
    out = list(paced(msgs, speed=2.0, clock=lambda: now[0], sleep=sleep))
    assert out == msgs
    # due times 0, .05, .15, .15, .30 after the start: overshoot is absorbed, not accumulated
    assert slept == pytest.approx([0.05, 0.098, 0.148])
    assert list(paced(msgs, speed=0, sleep=lambda dt: pytest.fail("no sleep at max speed"))) == msgs
    p = Pacer(1.0, clock=lambda: 0.0)
    assert p.wait_s(msg(10.0, 0x80)) == 0.0 and p.wait_s(msg(10.5, 0x80)) == pytest.approx(0.5)
    p.shift(2.0)  # a 2 s pause
    assert p.wait_s(msg(10.5, 0x80)) == pytest.approx(2.5)


def test_read_log_refuses_missing_and_foreign_files(tmp_path):
    with pytest.raises(ReplayError, match="no such log file"):
        read_log(tmp_path / "none.log")
    with pytest.raises(ReplayError, match="expected one of"):
        read_log(tmp_path / "x.txt")
    bad = tmp_path / "bad.blf"
    bad.write_bytes(b"not a blf file at all")
    with pytest.raises(ReplayError, match="bad.blf"):
        list(read_log(bad))


def test_monitor_cli_replays_a_log_as_json_and_refuses_bad_files(tmp_path, capsys):
    from telethermo.cli.main import EXIT_OK, EXIT_USAGE, main

    log = tmp_path / "s.asc"
    w = can.Logger(str(log))
    for k in range(1, 21):
        w.on_message_received(msg(1000.0 + 0.01 * k, 0x080, [k]))
        w.on_message_received(msg(1000.0 + 0.01 * k + 0.001, 0x181, struct.pack("<ff", 30.0 + k, 0.25)))
    w.stop()
    assert main(["monitor", "--replay", str(log), "--json", "--no-frames", "--status-every", "0"]) == EXIT_OK
    rows = [json.loads(ln) for ln in capsys.readouterr().out.splitlines()]
    (status,) = [r for r in rows if r["type"] == "status"]
    assert status["frames"] == 40 and status["syncs"] == 20 and status["sync_counter"] == 20
    assert status["sync"]["period_s"] == pytest.approx(0.01, abs=1e-5)
    (p,) = status["pdos"]
    assert p["count"] == 20 and p["values"][0] == {
        "name": "estimate_C",
        "value": 50.0,
        "unit": "degC",
        "index": 0x2100,
        "subindex": 0,
    }
    assert main(["monitor", "--replay", str(tmp_path / "nope.blf"), "--json"]) == EXIT_USAGE
    err = capsys.readouterr().err
    assert err.strip() == f"telethermo monitor: error: {tmp_path / 'nope.blf'}: no such log file"
