"""telethermo.cli.progress.Progress, the one progress display of the CLI: in place on a terminal, a plain line
~every 10 % elsewhere (a log, a pipe: never a carriage return); and ``identify`` into a pipe, a real
process."""

from __future__ import annotations

import io
import re
import subprocess
import sys

import pytest

from telethermo.cli.progress import Progress


def test_not_a_tty_prints_a_line_every_ten_percent_and_the_end():
    out = io.StringIO()  # not a terminal: isatty() is False
    bar = Progress("session", total=3000, unit="cycles", stream=out)
    for k in range(0, 3001, 7):  # polled far more often than every 10 %
        bar.update(k, rate=1234.0)
        bar.update(k, rate=1234.0)  # the same k twice: nothing new
    bar.update(3000, rate=1234.0)
    bar.close()
    lines = out.getvalue().splitlines()
    assert "\r" not in out.getvalue()
    assert len(lines) == 10
    pcts = [float(ln.split("(")[1].split("%")[0]) for ln in lines]
    assert all(p >= 10 * (i + 1) for i, p in enumerate(pcts)) and pcts[-1] == 100.0
    assert re.fullmatch(r"session  3000/3000 cycles  \(100\.0 %, 1,234 cycles/s\)  \d+\.\d s", lines[-1])


def test_a_tty_rewrites_one_line_in_place():
    out = io.StringIO()
    bar = Progress("identify: experiment", total=100, unit="samples", stream=out, tty=True)
    for k in (1, 2, 2, 50, 100):
        bar.update(k)
    bar.close()
    bar.close()
    text = out.getvalue()
    assert text.count("\r") == 4 and text.endswith("\n") and text.count("\n") == 1


def test_unknown_total_prints_every_thousand():
    out = io.StringIO()
    bar = Progress("session", total=0, unit="cycles", stream=out)
    for k in range(0, 3500, 10):
        bar.update(k)
    assert [ln.split("  (")[0] for ln in out.getvalue().splitlines()] == [
        f"session  {k}/? cycles" for k in (1000, 2000, 3000)
    ]


@pytest.mark.slow
def test_identify_into_a_pipe_writes_lines_not_frames(tmp_path):
    """Issue 25: `telethermo identify ... 2>&1 | cat` got `\\r` frames; a pipe now gets ~10 plain lines."""
    p = subprocess.run(
        [
            sys.executable,
            "-m",
            "telethermo",
            "identify",
            "--samples",
            "1200",
            "--validation",
            "200",
            "--out",
            str(tmp_path / "m.json"),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert p.returncode in (0, 1), p.stderr
    assert "\r" not in p.stderr and "\r" not in p.stdout
    lines = [ln for ln in p.stderr.splitlines() if ln.startswith("identify: experiment  ")]
    assert 5 <= len(lines) <= 11 and "(100.0 %)" in lines[-1], p.stderr
