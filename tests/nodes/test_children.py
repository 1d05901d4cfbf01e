"""Waiting for a child's ready line with a deadline (:func:`readline_within`): a child that hangs before it
prints must not hang its parent (the hub launcher, the I/O modules and three benchmarks wait this way).
Real child processes of this interpreter."""

from __future__ import annotations

import subprocess
import sys

import pytest

from telethermo.nodes.children import readline_within, stop_process

pytestmark = pytest.mark.slow


def _child(code: str) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, text=True, start_new_session=True
    )


def test_the_ready_line_is_returned_as_printed() -> None:
    proc = _child("import sys, time; print('ready', flush=True); time.sleep(30)")
    try:
        assert readline_within(proc, 30.0) == "ready\n"
    finally:
        assert stop_process(proc, timeout_s=5.0) is not None


def test_a_silent_child_gives_an_empty_line_after_the_deadline_not_a_hang() -> None:
    proc = _child("import time; time.sleep(60)")
    try:
        assert readline_within(proc, 0.5) == ""
        # it returned while the child still runs (a blocking read would end only with the child, 60 s on):
        # the deadline, not the pipe's end, gave the empty line; stopping the child is the caller's part
        assert proc.poll() is None
    finally:
        stop_process(proc, timeout_s=5.0)
    assert proc.poll() is not None


def test_a_child_that_exits_without_a_line_gives_an_empty_line() -> None:
    proc = _child("import sys; sys.exit(3)")
    assert readline_within(proc, 30.0) == ""
    assert proc.wait(10) == 3


def test_a_child_without_a_stdout_pipe_is_refused() -> None:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    try:
        with pytest.raises(ValueError, match="stdout=PIPE"):
            readline_within(proc, 1.0)
    finally:
        proc.wait(10)
