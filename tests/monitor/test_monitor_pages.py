"""The monitor's lab tools without a terminal: the raw frame list, bounded scrollback of frames and
events, the pages and keys, the controller state (error frames, python-can bus.state), the incident
hints, the readable status counters and the timing taken from the network file."""

from __future__ import annotations

import curses
import io
import struct
from pathlib import Path

import can
import pytest

from telethermo import bus_config
from telethermo.cli.monitor_setup import monitor_config as net_monitor_config
from telethermo.device.netconfig import load_network
from telethermo.monitor.frames import FRAME_HISTORY
from telethermo.monitor.health import decode_error_frame
from telethermo.monitor.hints import HEARTBEAT_LOST, emcy_hint, incident_hints
from telethermo.monitor.pages import KEYS, scroll_window, strip_chart
from telethermo.monitor.run import bus_state_poller, run_lines
from telethermo.monitor.state import Monitor
from telethermo.monitor.view import ViewState, handle_key, render_lines

from .conftest import monitor_config


def msg(t, cob, data=b"", **kw):
    return can.Message(timestamp=t, arbitration_id=cob, data=bytes(data), is_extended_id=False, **kw)


def cycles(mon: Monitor, n: int, period_s: float = 0.01, t0: float = 0.0) -> None:
    """Heartbeats of both nodes, then ``n`` SYNC cycles with both nodes' synchronous TPDO1 and TPDO5."""
    mon.feed(msg(t0, 0x701, [0x05]))
    mon.feed(msg(t0, 0x702, [0x05]))
    for k in range(1, n + 1):
        t = t0 + k * period_s
        mon.feed(msg(t, 0x080, [(k - 1) % 240 + 1]))
        mon.feed(msg(t + 0.001, 0x181, struct.pack("<ff", 30.0, -0.5)))
        mon.feed(msg(t + 0.002, 0x182, struct.pack("<ff", 24.0, 0.5)))
        mon.feed(msg(t + 0.003, 0x681, [1]))
        # the slave's TPDO5: contact flag, identified material, touches, beta (8 bytes, issue 15)
        mon.feed(msg(t + 0.004, 0x682, struct.pack("<BBHf", 1, 0, 0, 0.0)))


def no_prompt(label: str) -> str:
    raise AssertionError("no prompt expected")


def test_raw_frame_list_has_one_row_per_cob_id_with_count_period_and_last_data():
    mon = Monitor(monitor_config(sync_period_s=0.01))
    cycles(mon, 50)
    rows = {r.cob_id: r for r in mon.frames.sorted_rows()}
    assert set(rows) == {0x701, 0x702, 0x080, 0x181, 0x182, 0x681, 0x682}
    sync = rows[0x080]
    assert sync.count == 50 and sync.kind == "SYNC" and sync.data == bytes([50])
    assert sync.period_mean_s == pytest.approx(0.01) and sync.period_max_s == pytest.approx(0.01)
    assert rows[0x181].node == 1 and "estimate_C=30.000" in rows[0x181].text
    vs = ViewState(page="raw")
    text = "\n".join(render_lines(mon, vs, 160, 20))
    assert "RAW FRAME LIST (7 identifiers)" in text
    line = next(ln for ln in text.splitlines() if ln.startswith("     080"))
    assert line.split()[1:4] == ["SYNC", "-", "50"] and "10.00" in line and "[1] 32" in line
    assert mon.snapshot()["cob_ids"][0]["cob_id"] == 0x080


def test_frame_history_is_bounded_and_scrolls_back_to_the_oldest_kept():
    mon = Monitor(monitor_config(sync_period_s=0.01))
    cycles(mon, 1000)  # 5002 frames
    hist = mon.frames.history
    assert len(hist) == FRAME_HISTORY and hist[-1].cob_id == 0x682
    vs = ViewState(page="log")
    newest = render_lines(mon, vs, 140, 20)
    assert f"lines {FRAME_HISTORY - 14}-{FRAME_HISTORY} of {FRAME_HISTORY}" in newest[3]
    assert handle_key(vs, mon, curses.KEY_HOME, 15, no_prompt) and vs.scroll > 0
    oldest = render_lines(mon, vs, 140, 20)
    assert f"lines 1-15 of {FRAME_HISTORY}" in oldest[3] and "newer below" in oldest[3]
    first_kept = hist[0]
    assert f"0x{first_kept.cob_id:03X}" in oldest[4] and oldest[4] != newest[4]
    handle_key(vs, mon, curses.KEY_NPAGE, 15, no_prompt)
    assert vs.scroll > 0
    handle_key(vs, mon, curses.KEY_END, 15, no_prompt)
    assert vs.scroll == 0 and render_lines(mon, vs, 140, 20) == newest


def test_events_scroll_back_on_the_main_page_and_the_event_page():
    mon = Monitor(monitor_config(sync_period_s=0.01))
    cycles(mon, 5)
    for k in range(40):  # 40 SDO aborts: 40 warnings
        mon.feed(msg(1.0 + k, 0x601, struct.pack("<BHBf", 0x23, 0x2200, 0, 25.0)))
        mon.feed(msg(1.0 + k + 0.001, 0x581, struct.pack("<BHBL", 0x80, 0x2200, 0, 0x06090031)))
    vs = ViewState()
    last = "\n".join(render_lines(mon, vs, 140, 30))
    n = len(mon.log.events)
    assert n == 44 and f"of {n}" in last and "newer below" not in last
    handle_key(vs, mon, curses.KEY_UP, 10, no_prompt)
    handle_key(vs, mon, ord("k"), 10, no_prompt)
    assert vs.scroll == 2 and "2 newer below" in "\n".join(render_lines(mon, vs, 140, 30))
    handle_key(vs, mon, ord("e"), 10, no_prompt)
    assert vs.page == "events" and vs.scroll == 0
    page = render_lines(mon, vs, 140, 30)
    assert page[3].startswith("EVENT LOG (last 1000 kept)") and sum(" WARN " in ln for ln in page) == 25
    handle_key(vs, mon, ord("c"), 10, no_prompt)
    assert not mon.log.events and not mon.frames.history and mon.frames.rows


def test_help_page_lists_every_key_and_toggles_back():
    mon = Monitor(monitor_config())
    vs = ViewState()
    assert handle_key(vs, mon, ord("?"), 10, no_prompt) and vs.page == "help"
    text = "\n".join(render_lines(mon, vs, 140, 40))
    for key, what in KEYS:
        assert key in text and what in text
    handle_key(vs, mon, ord("h"), 10, no_prompt)
    assert vs.page == "main"
    handle_key(vs, mon, ord("?"), 10, no_prompt)
    handle_key(vs, mon, 27, 10, no_prompt)
    assert vs.page == "main"
    assert not handle_key(vs, mon, ord("q"), 10, no_prompt)


def test_scroll_window_clamps():
    assert scroll_window(list(range(5)), 10, 3) == ([0, 1, 2, 3, 4], "")
    assert scroll_window(list(range(20)), 5, 100) == (
        [0, 1, 2, 3, 4],
        "lines 1-5 of 20, 15 newer below (End to follow)",
    )
    assert scroll_window(list(range(20)), 0, 0) == ([], "")


def test_socketcan_error_frames_give_controller_state_and_counters():
    # linux/can/error.h: CAN_ERR_CRTL (0x4) | CAN_ERR_CNT (0x200); data[1] = CAN_ERR_CRTL_RX_PASSIVE (0x10)
    passive = decode_error_frame(0x204, bytes([0, 0x10, 0, 0, 0, 0, 96, 130]))
    assert passive["state"] == "ERROR-PASSIVE" and (passive["tx_errors"], passive["rx_errors"]) == (96, 130)
    assert passive["classes"] == ["controller", "counters"] and passive["controller"] == ["RX passive"]
    assert decode_error_frame(0x040, bytes(8))["state"] == "BUS-OFF"
    mon = Monitor(monitor_config())
    evs = mon.feed(
        can.Message(
            timestamp=1.0,
            arbitration_id=0x204,
            is_error_frame=True,
            data=bytes([0, 0x10, 0, 0, 0, 0, 96, 130]),
        )
    )[1]
    assert [e.kind for e in evs] == ["error_frame", "controller_state"]
    assert "unknown -> ERROR-PASSIVE" in evs[1].text
    head = render_lines(mon, ViewState(), 200, 10)[2]
    assert "controller: ERROR-PASSIVE (from error frame)  TX errors 96  RX errors 130" in head
    assert mon.snapshot()["controller"]["rx_errors"] == 130
    hints = incident_hints(mon)
    assert any("error-passive" in h for h in hints) and any("termination" in h for h in hints)


def test_virtual_bus_says_its_controller_state_is_unavailable():
    bus = can.Bus(interface="virtual", channel="tt-monitor-pages-state")
    try:
        mon = Monitor(monitor_config())
        bus_state_poller(bus)(mon)
        assert mon.controller.state is None
        assert (
            "controller: unavailable (virtual bus: no controller)"
            in render_lines(mon, ViewState(), 200, 5)[2]
        )
    finally:
        bus.shutdown()
    mon.set_bus_state("PASSIVE")  # an interface that implements bus.state (pcan, ixxat, ...)
    assert mon.controller.text() == "controller: ERROR-PASSIVE (from bus.state)"


def test_incident_hints_for_heartbeat_loss_emcy_jitter_late_cycles_and_load():
    mon = Monitor(monitor_config(sync_period_s=0.01))
    cycles(mon, 20)
    assert incident_hints(mon) == []
    mon.feed(msg(0.30, 0x082, struct.pack("<HB5s", 0x4210, 0x09, b"\x00" * 5)))
    mon.tick(5.0)  # no heartbeat for > the timeout
    hints = incident_hints(mon)
    assert f"node 1 master: {HEARTBEAT_LOST}" in hints and f"node 2 slave: {HEARTBEAT_LOST}" in hints
    assert "node 2 slave: " + emcy_hint(0x4210) in hints and "heat sink" in emcy_hint(0x4210)
    assert emcy_hint(0x8130).startswith("EMCY communication") and emcy_hint(0x2310).startswith("EMCY current")
    jittery = Monitor(monitor_config(sync_period_s=0.01))
    t = 0.0
    for k in range(40):
        t += 0.006 if k % 2 else 0.016  # mean 11 ms, jitter 5 ms, every other cycle late
        jittery.feed(msg(t, 0x080, [k % 240 + 1]))
    text = " | ".join(incident_hints(jittery))
    assert "SYNC jitter 5.00 ms (50% of 10.00 ms)" in text and "19 late SYNC cycles" in text
    busy = Monitor(monitor_config(bitrate_bps=125_000))
    for k in range(2000):
        busy.feed(msg(k * 0.001, 0x181, bytes(8)))
    assert any(h.startswith("bus load") for h in incident_hints(busy))
    screen = "\n".join(render_lines(mon, ViewState(), 200, 50))
    assert "CHECK FIRST (4; [i] for all)" in screen and "no frame for 5 s since the last one" in screen


def test_status_bar_names_its_counters():
    mon = Monitor(monitor_config(sync_period_s=0.01))
    cycles(mon, 3)
    mon.feed(msg(0.1, 0x082, struct.pack("<HB5s", 0x4210, 0x09, b"\x00" * 5)))
    rates, status = render_lines(mon, ViewState(), 300, 5)[1:3]
    assert "events: 0 warnings, 1 errors" in status and "late cycles 0" in status
    assert "missed PDOs 0" in status and "error frames 0" in status
    assert "(nominal 10.00, timing unknown)" in rates


def test_sync_period_and_heartbeat_consumer_time_come_from_the_network_file(tmp_path):
    src = Path(bus_config.__file__).resolve().parent
    text = (src / "network.toml").read_text()
    text = text.replace("period_s = 0.010", "period_s = 0.020").replace(
        "consumer_ms = 250", "consumer_ms = 400"
    )
    assert "lockstep = true" in text
    for eds in ("master.eds", "slave.eds"):
        (tmp_path / eds).write_bytes((src / eds).read_bytes())
    (tmp_path / "network.toml").write_text(text)
    mon = Monitor(net_monitor_config(load_network(tmp_path / "network.toml")))
    assert mon.config.sync_period_s == 0.020 and mon.config.sync_lockstep
    assert mon.nodes[1].consumer_time_s == 0.4 and mon.nodes[2].hb_timeout_s == 0.4
    for k, t in enumerate((0.0, 0.02, 0.04, 0.10)):  # the last SYNC 60 ms after the one before
        mon.feed(msg(t, 0x080, [k + 1]))
    assert mon.stats.late_cycles == 1
    snap = mon.snapshot()
    assert snap["sync_period_nominal_s"] == 0.020 and snap["network_file_lockstep"] is True
    # issue 25: the file says lockstep, but 3 SYNC intervals cannot tell the bus's timing
    assert snap["sync_lockstep"] is None
    assert snap["sync_timing_evidence"] == "3 SYNC intervals seen, 20 needed to tell"
    assert "(nominal 20.00, timing unknown)" in render_lines(mon, ViewState(), 300, 5)[1]


def test_a_silent_live_bus_gets_a_hint_and_a_replay_does_not():
    mon = Monitor(monitor_config())
    mon.tick(100.0)
    mon.tick(102.0)
    assert incident_hints(mon) == []
    mon.tick(103.5)
    assert incident_hints(mon)[0].startswith("no frame on the bus for 4 s: check the bus setting")
    mon.feed(msg(104.0, 0x701, [0x05]))
    assert not any(h.startswith("no frame") for h in incident_hints(mon))
    mon.tick(110.0)
    assert any(h.startswith("no frame for 6 s since the last one") for h in incident_hints(mon))
    replay = Monitor(monitor_config())
    replay.feed(msg(1.0, 0x701, [0x05]))
    replay.feed(msg(100.0, 0x702, [0x05]))
    assert not any(h.startswith("no frame") for h in incident_hints(replay))


def test_strip_chart_of_the_exchanged_temperatures():
    assert strip_chart([0.0, 1.0, 2.0, 3.0, float("nan"), 3.0], 10, rows=4) == [
        "   * *",
        "  *   ",
        " *    ",
        "*     ",
    ]
    mon = Monitor(monitor_config(sync_period_s=0.01))
    for k in range(500):  # 5 s of bus time: a ramp on the master, constant on the slave
        mon.feed(msg(k * 0.01, 0x181, struct.pack("<ff", 30.0 + 0.002 * k, -0.5)))
        mon.feed(msg(k * 0.01 + 0.001, 0x182, struct.pack("<ff", 24.0, 0.5)))
    trace = mon.pdos[(1, "TPDO", 1)].trace
    assert len(trace) == 50 and trace[1][0] - trace[0][0] == pytest.approx(0.1)
    vs = ViewState()
    handle_key(vs, mon, ord("t"), 10, no_prompt)
    lines = render_lines(mon, vs, 100, 20)
    assert lines[3].startswith("TEMPERATURES")
    assert "master TPDO1 estimate_C = 30.998 degC   [30.000..30.980 degC, last 5 s]" in lines[4]
    assert (
        lines[5].startswith("   30.980 |")
        and lines[5].rstrip().endswith("*")
        and lines[8].startswith("   30.000 |*")
    )
    assert "slave TPDO1 estimate_C = 24.000 degC" in "\n".join(lines)


def test_lines_status_names_the_controller_state_once_known():
    frames = [
        msg(0.0, 0x701, [0x05]),
        can.Message(
            timestamp=0.5, arbitration_id=0x004, is_error_frame=True, data=bytes([0, 0x20, 0, 0, 0, 0, 0, 0])
        ),
    ]
    out = io.StringIO()
    run_lines(iter(frames), Monitor(monitor_config()), out, as_json=False, frames=False, status_every_s=0)
    status = out.getvalue().strip().splitlines()[-1]
    assert " STATUS " in status and status.endswith("| controller ERROR-PASSIVE")
    assert "WARN  CAN controller unknown -> ERROR-PASSIVE" in out.getvalue()
