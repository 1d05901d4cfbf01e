"""nodes.launch.ProgressLine: in place on a terminal, ~every 10 % as plain lines elsewhere (a log, a pipe)."""
from __future__ import annotations

import io

from telethermo.nodes.launch import ProgressLine


def test_not_a_tty_prints_a_line_every_ten_percent_and_the_end():
    out = io.StringIO()            # not a terminal: isatty() is False
    bar = ProgressLine(out, total=3000)
    for k in range(0, 3001, 7):     # polled far more often than every 10 %
        bar.update(k, rate=1234.0)
        bar.update(k, rate=1234.0)  # the same k twice: nothing new
    bar.update(3000, rate=1234.0)
    bar.close()
    lines = out.getvalue().splitlines()
    assert "\r" not in out.getvalue()
    assert len(lines) == 10
    pcts = [float(ln.split("(")[1].split("%")[0]) for ln in lines]
    assert all(p >= 10 * (i + 1) for i, p in enumerate(pcts)) and pcts[-1] == 100.0
    assert lines[-1] == "  cycle 3000/3000  (100.0 %, 1,234 cycles/s)"


def test_a_tty_rewrites_one_line_in_place():
    out = io.StringIO()
    bar = ProgressLine(out, total=100, tty=True)
    for k in (1, 2, 50, 100):
        bar.update(k)
    bar.close()
    text = out.getvalue()
    assert text.count("\r") == 4 and text.endswith("\n") and text.count("\n") == 1


def test_unknown_total_prints_every_thousand_cycles():
    out = io.StringIO()
    bar = ProgressLine(out, total=0)
    for k in range(0, 3500, 10):
        bar.update(k)
    assert out.getvalue().splitlines() == [f"  cycle {k}/?  (  0.0 %)" for k in (1000, 2000, 3000)]
