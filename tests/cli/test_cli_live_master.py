"""A master node process alone on our hub (a pad in air, lockstep, idle), driven by the CLI: `get`
shows what the running node holds in the operator's format, and `set` refusals say the rule that refused
(the node's controller validates across objects: T_min_C must not exceed neutral_C)."""

from __future__ import annotations


import pytest

from telethermo.nodes.launch import wait_for
from telethermo.cli.main import EXIT_FAIL, EXIT_OK, main

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def bus(lone_master):
    return lone_master[0]


def cli(capsys, *argv):
    code = main(list(argv))
    o = capsys.readouterr()
    return code, o.out, o.err


def test_get_from_the_running_node(bus, capsys):
    assert wait_for(
        lambda: cli(capsys, "get", "--bus", bus, "--timeout", "0.3", "master", "mode")[0] == EXIT_OK, 30
    )
    code, out, err = cli(
        capsys,
        "get",
        "--bus",
        bus,
        "master",
        "COB-ID SYNC",
        "mode",
        "estimator",
        "safety_state",
        "0x1A00:1",
        "T_sensor_C",
    )
    assert code == EXIT_OK, err
    vals = dict(ln.split("    (")[0].split(" = ", 1) for ln in out.splitlines())
    assert vals == {
        "master 0x1005 COB-ID SYNC": "0x40000080 (COB-ID 0x080, produces SYNC)",  # the SYNC producer
        "master 0x2500 mode": "0 (idle)",
        "master 0x2203 estimator": "1 (flux)",
        "master 0x2700 safety_state": vals["master 0x2700 safety_state"],
        "master 0x1A00:01 TPDO1 mapping parameter.Application object 1": (
            "0x21000020 (0x2100:00 estimate_C, 32 bits)"
        ),
        "master 0x2000 T_sensor_C": vals["master 0x2000 T_sensor_C"],
    }
    assert vals["master 0x2700 safety_state"] in ("0 (ok)", "1 (limiting)")
    assert vals["master 0x2000 T_sensor_C"].endswith(" degC")


def test_set_refusal_says_the_rule(bus, capsys):
    assert wait_for(
        lambda: cli(capsys, "get", "--bus", bus, "--timeout", "0.3", "master", "mode")[0] == EXIT_OK, 30
    )
    code, out, err = cli(capsys, "set", "--bus", bus, "master", "T_min_C", "40")  # in the EDS range [15, 43]
    assert code == EXIT_FAIL and out == "" and err.count("\n") == 1
    assert err.startswith(
        "telethermo set: master (node 1) refused T_min_C = 40.0: SDO abort 0x06090030: "
        "Invalid value for parameter (download only); T_min_C: lowest surface setpoint, "
        "must not exceed neutral_C"
    )
    assert err.rstrip().endswith("(now neutral_C = 32 degC, T_max_C = 43 degC)")
    assert cli(capsys, "get", "--bus", bus, "master", "T_min_C")[1].startswith(
        "master 0x2400 T_min_C = 15 degC"
    )
    # a rule of the device state: the model estimator needs a loaded model
    code, _, err = cli(capsys, "set", "--bus", bus, "master", "estimator", "model")
    assert code == EXIT_FAIL and "SDO abort 0x08000022" in err
    assert "(0 and 2 need a loaded model: model_status 1) (now model_status = 0 (no model))" in err


def test_sdo_on_the_running_node(bus, capsys):
    assert wait_for(
        lambda: cli(capsys, "get", "--bus", bus, "--timeout", "0.3", "master", "mode")[0] == EXIT_OK, 30
    )
    code, out, err = cli(capsys, "sdo", "--bus", bus, "master", "0x1017")
    assert code == EXIT_OK and out == "master 0x1017:00 Producer heartbeat time = 100 ms\n", err
    code, out, err = cli(capsys, "sdo", "--bus", bus, "1", "0x1008", "--type", "str")  # segmented upload
    assert code == EXIT_OK and out == "master 0x1008:00 Manufacturer device name = 'telethermo master'\n", err
    code, out, err = cli(capsys, "sdo", "--bus", bus, "1", "0x2200", "0.5", "--type", "f32")
    assert code == EXIT_OK and out == "master 0x2200:00 kp_A_per_C <- 00 00 00 3f (REAL32 0.5): written\n", (
        err
    )
    assert cli(capsys, "get", "--bus", bus, "master", "kp_A_per_C")[1].startswith(
        "master 0x2200 kp_A_per_C = 0.5 "
    )
    # aborts, with the CiA 301 text of each code
    for argv, expected in [
        (["0x1018:7"], "master 0x1018:07: read refused: SDO abort 0x06090011: Sub-index does not exist"),
        (
            ["0x5FFF"],
            "master 0x5FFF:00: read refused: SDO abort 0x06020000: "
            "Object does not exist in the object dictionary",
        ),
        (
            ["0x1000", "5", "--type", "u32"],
            "master 0x1000:00: write refused: SDO abort 0x06010002: Attempt to write a read only object",
        ),
        (
            ["0x2400", "40", "--type", "f32"],
            "master 0x2400:00: write refused: SDO abort 0x06090030: "
            "Invalid value for parameter (download only)",
        ),
    ]:
        code, out, err = cli(capsys, "sdo", "--bus", bus, "1", *argv)
        assert code == EXIT_FAIL and out == "" and err == f"telethermo sdo: {expected}\n", argv


def test_a_target_beyond_the_skin_clamp_saturates_and_status_says_so(bus, capsys):
    """Render brass at 60 °C: eq. 7's pre-set lies beyond the skin's 43 °C clamp, so the setpoint saturates at
    the clamp (no trip, no cut) and `status` names the limit; back to idle, the limit clears (issue 22)."""
    import canopen

    from telethermo.bus_config import path as eds_path
    from telethermo.control.safety_limits import limits_from_mask

    assert wait_for(
        lambda: cli(capsys, "get", "--bus", bus, "--timeout", "0.3", "master", "mode")[0] == EXIT_OK, 30
    )
    code, out, err = cli(capsys, "mode", "--bus", bus, "render", "brass", "--object-temp", "60")
    assert code == EXIT_OK, err
    net = canopen.Network()
    host, port_channel = bus.split("://")[1].split(":", 1)
    port, channel = port_channel.split("/", 1)
    net.connect(interface="socketcand", host=host, port=int(port), channel=channel)
    try:
        node = net.add_node(canopen.RemoteNode(1, str(eds_path("master.eds"))))
        seen = []
        assert wait_for(
            lambda: (
                seen.append(node.sdo["limits_active"].raw) or "setpoint_clamp" in limits_from_mask(seen[-1])
            ),
            20,
        ), seen
        assert node.sdo["safety_state"].raw in (1,)  # limiting, not cut
        assert node.sdo["T_cmd_C"].raw <= 43.0 + 1e-4  # the setpoint sits at the clamp
        assert node.sdo["active_trips"].raw == 0
        code, out, err = cli(capsys, "status", "--bus", bus, "master")
        assert code == EXIT_OK, err
        line = next(ln for ln in out.splitlines() if ln.strip().startswith("limits"))
        # the lone master runs its own lockstep SYNC, faster than real time: on a loaded machine the pad can
        # have sat above hot_C for hot_time_limit_s (30 s of its time) by now, and the time-at-temperature cap
        # (40 °C) then holds the setpoint below the clamp. Either way a limit holds it and status names that
        # limit.
        assert "setpoint_clamp" in line or "hot_cap" in line, out
    finally:
        back = cli(capsys, "set", "--bus", bus, "master", "mode", "idle")  # `mode` wants the slave too
        net.disconnect()
    assert back[0] == EXIT_OK, back
    assert wait_for(
        lambda: cli(capsys, "get", "--bus", bus, "master", "mode")[1].startswith("master 0x2500 mode = 0"), 20
    ), cli(capsys, "get", "--bus", bus, "master", "mode")
