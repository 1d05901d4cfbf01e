"""The typed run results (issue 26.3): the SYNC producer's ``result {json}`` line and a session's ``run``
block keep their JSON byte for byte (the key order the programs wrote before they were typed), and a
wrong or missing field is named. The real programs' lines are checked in tests/nodes/test_node_terminal.py
and tests/nodes/test_session_cli.py."""

from __future__ import annotations

import json

import pytest
from hypothesis import given
from hypothesis import strategies as st

from telethermo.recording.result import (
    RESULT_PREFIX,
    IoRigCounters,
    RealtimeFigures,
    RunResult,
    SessionRun,
)

# A lockstep producer's result as nodes/main.py wrote it as a hand-built dict (keys in its order).
LOCKSTEP = {
    "cycles": 300,
    "wall_s": 1.25,
    "cycles_per_s": 240.0,
    "timing": "lockstep",
    "period_s": 0.01,
    "late_cycles": 0,
    "lockstep_timeouts": 2,
    "sync_to_tpdo_ms_p50": 1.709,
    "sync_to_tpdo_ms_p99": 7.683,
    "sync_to_tpdo_n": 298,
    "cycle_ms_p50": 0.4,
    "cycle_ms_p99": None,
    "emcy_raised": 1,
    "peer": {"pdos": 298, "missed_cycles": 2, "losses": 0, "returns": 0, "non_finite": 0},
    "bus": None,
}
# ... and a real-time one: the ticker's keys follow, in this order.
REALTIME = dict(
    LOCKSTEP,
    timing="realtime",
    bus={"outages": 1, "reopens": 1, "attempts": 3, "frames_dropped": 7, "down_s": 0.5, "last_reason": "x"},
    lateness_ms_p50=0.02,
    lateness_ms_p99=None,
    lateness_ms_max=3.5,
    overruns=1,
    late_tolerance_ms=2.0,
)


@pytest.mark.parametrize("legacy", [LOCKSTEP, REALTIME], ids=["lockstep", "realtime"])
def test_the_result_line_is_byte_compatible(legacy):
    line = RESULT_PREFIX + json.dumps(legacy)
    r = RunResult.from_line(line)
    assert r is not None
    assert r.to_line() == line
    assert list(r.to_dict()) == list(legacy)
    assert (r.realtime is None) == (legacy["timing"] == "lockstep")


def test_an_io_rig_producer_carries_its_counters_and_other_rigs_none():
    """``--rig io``: the I/O rig's counters (0x2709 input_timeouts, 0x270A module_restarts) follow the
    ticker's keys; any other rig writes neither key and reads back None."""
    io_line = dict(REALTIME, input_timeouts=3, module_restarts=2)
    r = RunResult.from_dict(io_line)
    assert r.io_rig == IoRigCounters(input_timeouts=3, module_restarts=2)
    assert r.to_json() == json.dumps(io_line) and list(r.to_dict())[-2:] == [
        "input_timeouts",
        "module_restarts",
    ]
    for legacy in (LOCKSTEP, REALTIME):
        plain = RunResult.from_dict(legacy)
        assert plain.io_rig is None and "module_restarts" not in plain.to_dict()
    with pytest.raises(ValueError, match="master's line: missing field 'input_timeouts'"):
        RunResult.from_dict(dict(LOCKSTEP, module_restarts=1), "master's line")
    with pytest.raises(ValueError, match="field 'module_restarts': expected int"):
        RunResult.from_dict(dict(LOCKSTEP, input_timeouts=0, module_restarts=1.5))
    block = {
        "transport": "socketcand",
        "wall_time_s": 14.9,
        "cycles": 300,
        "cycles_requested": 300,
        "cycles_per_s": 20.1,
        "complete": True,
        "master": dict(LOCKSTEP, input_timeouts=0, module_restarts=1),
        "io_modules": {"master": 3, "slave": 4},
    }
    run = SessionRun.from_json(json.dumps(block))  # the session summary's run block
    assert run.master is not None and run.master.io_rig == IoRigCounters(0, 1)
    assert run.to_json() == json.dumps(block)


def test_the_typed_fields_carry_the_values():
    r = RunResult.from_dict(REALTIME)
    assert r.cycles == 300 and r.wall_s == 1.25 and r.period_s == 0.01 and r.peer["pdos"] == 298
    assert r.realtime == RealtimeFigures(0.02, None, 3.5, 1, 2.0)
    assert RunResult.from_line("progress 1 300") is None


@pytest.mark.parametrize(
    "change, field, expected",
    [
        ({"cycles": None}, "cycles", "expected int"),
        ({"cycles": True}, "cycles", "expected int"),
        ({"wall_s": "1.2"}, "wall_s", "expected int or float"),
        ({"peer": []}, "peer", "expected dict"),
        ({"overruns": 1}, "lateness_ms_p50", "missing field"),
    ],
)
def test_a_wrong_field_is_named(change, field, expected):
    with pytest.raises(ValueError) as exc:
        RunResult.from_dict(dict(LOCKSTEP, **change), "master's line")
    msg = str(exc.value)
    assert msg.startswith("master's line: ") and repr(field) in msg and expected in msg, msg
    bad = dict(LOCKSTEP)
    del bad["sync_to_tpdo_n"]
    with pytest.raises(ValueError, match="run result: missing field 'sync_to_tpdo_n'"):
        RunResult.from_json(json.dumps(bad))
    with pytest.raises(ValueError, match="run result: expected a JSON object"):
        RunResult.from_json("[1]")


def test_the_session_run_block_round_trips():
    block = {
        "transport": "socketcand",
        "wall_time_s": 14.9,
        "cycles": 300,
        "cycles_requested": 300,
        "cycles_per_s": 20.1,
        "complete": True,
        "master": LOCKSTEP,
        "io_modules": None,
    }
    run = SessionRun.from_json(json.dumps(block))
    assert run.master == RunResult.from_dict(LOCKSTEP)
    assert run.to_json() == json.dumps(block)
    no_master = dict(block, master=None, io_modules={"slave": 4, "master": 3}, complete=False)
    assert SessionRun.from_dict(no_master).to_json() == json.dumps(no_master)
    with pytest.raises(ValueError, match="session run: master: missing field 'cycles'"):
        SessionRun.from_dict(dict(block, master={}))
    with pytest.raises(ValueError, match="session run: field 'complete': expected bool"):
        SessionRun.from_dict(dict(block, complete=1))


finite = st.floats(allow_nan=False, allow_infinity=False)


@given(
    cycles=st.integers(0, 10**9),
    wall_s=finite,
    p50=st.none() | finite,
    counters=st.dictionaries(st.text(max_size=8), st.integers()),
)
def test_any_result_round_trips_through_its_line(cycles, wall_s, p50, counters):
    r = RunResult.from_dict(
        dict(LOCKSTEP, cycles=cycles, wall_s=wall_s, sync_to_tpdo_ms_p50=p50, peer=counters)
    )
    back = RunResult.from_line(r.to_line())
    assert back == r and back.to_line() == r.to_line()
