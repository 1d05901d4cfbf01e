"""Issue 25, live writes that surprised: on a real master node process (our hub, a pad in air, lockstep),
`set master sink_trip_C 20` while it drives current cut the current with no word; `set` did not say which
mode's gain it wrote; `mode render wood` stored material code 0 (custom) and left the slave silently."""

from __future__ import annotations

import re

import pytest

from telethermo.cli.main import EXIT_OK, EXIT_USAGE, main
from telethermo.control.render_table import load_render_table
from telethermo.nodes.launch import wait_for

pytestmark = pytest.mark.slow


def cli(capsys, *argv):
    code = main(list(argv))
    o = capsys.readouterr()
    return code, o.out, o.err


def get(capsys, bus, name) -> str:
    code, out, err = cli(capsys, "get", "--bus", bus, "master", name)
    assert code == EXIT_OK, err
    return out.split(" = ", 1)[1].split()[0]


def test_render_then_live_safety_writes_say_what_they_do(lone_master, capsys):
    bus, _ = lone_master
    assert wait_for(
        lambda: cli(capsys, "get", "--bus", bus, "--timeout", "0.3", "master", "mode")[0] == EXIT_OK, 30
    )
    # no slave on this bus: render says so, and still renders
    code, out, err = cli(capsys, "mode", "--bus", bus, "--timeout", "0.3", "render", "wood")
    assert code == EXIT_OK, err
    assert (
        out.splitlines()[0] == "slave (node 2): not answering, so not set to idle (the master renders alone)"
    )
    wood = 1 + list(load_render_table()).index("wood")
    assert get(capsys, bus, "material_code") == str(wood) and get(capsys, bus, "mode") == "2"
    assert float(get(capsys, bus, "material_beta")) == pytest.approx(0.74, rel=1e-6)

    # a gain: which mode's
    code, out, err = cli(capsys, "set", "--bus", bus, "master", "kp_A_per_C", "0.6")
    assert code == EXIT_OK, err
    assert out.splitlines()[1] == (
        "  kp_A_per_C written for the render mode (the node's mode now); each mode keeps its "
        "own gains: set it again after `telethermo mode ...` to change another mode's"
    )

    # a safety limit the heat sink already breaks: refused with the rule, nothing sent
    sink = float(get(capsys, bus, "T_sink_C"))
    assert sink > 20.5, sink  # the scene's sink: above the lowest sink_trip_C the EDS allows
    code, out, err = cli(capsys, "set", "--bus", bus, "master", "sink_trip_C", "20")
    assert code == EXIT_USAGE and out == ""
    assert re.fullmatch(
        r"telethermo set: error: sink_trip_C 20 is below the heat sink's \d+\.\d °C: the heat-sink trip "
        r"latches at the next cycle and the current is cut \(master in render\); not sent: a safety "
        r"limit the node already breaks needs --force\n",
        err,
    ), err
    assert float(get(capsys, bus, "sink_trip_C")) == 55.0
    # a limit the readings do not break is written with no comment
    code, out, err = cli(capsys, "set", "--bus", bus, "master", "sink_trip_C", "54")
    assert code == EXIT_OK and len(out.splitlines()) == 1, (out, err)

    # --force: sent, the line says what happens, and it happens
    code, out, err = cli(capsys, "set", "--bus", bus, "master", "sink_trip_C", "20", "--force")
    assert code == EXIT_OK, err
    assert out.splitlines()[1].startswith("  sink_trip_C 20 is below the heat sink's ")
    assert wait_for(lambda: get(capsys, bus, "safety_state") == "3", 10)  # current cut
    assert cli(capsys, "set", "--bus", bus, "master", "sink_trip_C", "55")[0] == EXIT_OK
    assert cli(capsys, "set", "--bus", bus, "master", "mode", "idle")[0] == EXIT_OK
    assert wait_for(lambda: cli(capsys, "fault-reset", "--bus", bus, "master")[0] == EXIT_OK, 10)
