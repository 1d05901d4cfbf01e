"""The node programs' real-time options (issue 12): parsed with one-line errors, applied as far as the
system permits, each reported; a refused knob is a warning, never a failure. On this machine (a container
without CAP_SYS_NICE, as a lab PC without root) SCHED_FIFO is refused or granted; both give a line."""

from __future__ import annotations

import gc
import os

import pytest

from telethermo.control.types import Role
from telethermo.nodes.options import OptionError, build_parser, options_from_args
from telethermo.nodes.realtime import RealtimeOptions, apply_realtime, parse_cpus


def parse(*extra: str):
    argv = ["--bus", "virtual:x", "--scene", "pads_in_air", *extra]
    return options_from_args(Role.MASTER, build_parser(Role.MASTER).parse_args(argv))


def test_options_reach_the_node():
    o = parse("--cpu", "0", "--rt-priority", "50", "--nice", "5", "--mlock", "--gc", "freeze").realtime
    assert o == RealtimeOptions(cpus=(0,), rt_priority=50, nice=5, mlock=True, gc_freeze=True)
    assert parse().realtime == RealtimeOptions()


@pytest.mark.parametrize(
    "extra, message",
    [
        (("--cpu", "a"), "--cpu 'a': expected CPU numbers"),
        (("--rt-priority", "0"), "--rt-priority 0: expected 1..99"),
        (("--nice", "40"), "--nice 40: expected -20..19"),
    ],
)
def test_bad_values_are_one_line(extra, message):
    with pytest.raises(OptionError, match=message):
        parse(*extra)


def test_parse_cpus():
    assert parse_cpus("2,3,2") == (2, 3)
    with pytest.raises(ValueError):
        parse_cpus("-1")


def test_each_knob_is_applied_or_refused_with_a_line():
    before = os.sched_getaffinity(0)
    cpu = min(before)
    try:
        notes = apply_realtime(RealtimeOptions(cpus=(cpu,), rt_priority=10, gc_freeze=True))
        assert notes[0] == f"cpu: pinned to CPU [{cpu}]" and os.sched_getaffinity(0) == {cpu}
        assert notes[1] == "rt-priority: SCHED_FIFO 10" or notes[1].startswith("WARNING rt-priority:")
        assert notes[2].startswith("gc: ") and gc.get_freeze_count() > 0
        missing = max(before) + 1000
        assert apply_realtime(RealtimeOptions(cpus=(missing,)))[0].startswith(f"WARNING cpu: CPU [{missing}]")
    finally:
        os.sched_setaffinity(0, before)
        if os.sched_getscheduler(0) == os.SCHED_FIFO:
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
        gc.unfreeze()
        gc.set_threshold(700, 10, 10)
