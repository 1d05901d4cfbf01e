"""Other devices on the bus (issue 13: a bench also has a robot arm, I/O modules, thermocouple amplifiers):
the network file names them (``[nodes.NAME]``, node-ID required, EDS optional); the CLI reaches them by name,
by object name when their EDS is given, by raw SDO and NMT when it is not, and by any node-ID 1..127 even
outside the file. Checked against real CiA 301 devices on a python-can virtual bus, read back through
canopen's own client."""

from __future__ import annotations

import pytest

from telethermo.bus_config import path as bc
from telethermo.device.device import Device
from telethermo.device.netconfig import NetworkConfigError, load_network
from telethermo.device.settings import DeviceSettings

import canopen

NET = """
[bus]
interface = "virtual"
channel = "tt-other"
[nodes.master]
eds = "{master}"
[nodes.slave]
eds = "{slave}"
[nodes.arm]
node_id = 5
[nodes.amplifier]
node_id = 6
eds = "{slave}"
"""


def network(tmp_path, text=NET):
    p = tmp_path / "network.toml"
    p.write_text(text.format(master=bc("master.eds"), slave=bc("slave.eds")), encoding="utf-8")
    return p


def test_other_nodes_load_with_their_id_and_optional_eds(tmp_path):
    net = load_network(network(tmp_path))
    assert net.node("arm").node_id == 5 and net.node("arm").eds is None
    assert net.node("amplifier").eds == bc("slave.eds").resolve()
    assert set(net.device_settings("master").known_node_ids) == {1, 2, 5, 6}


@pytest.mark.parametrize(
    "extra, message",
    [
        ('[nodes.arm2]\neds = "x"\n', r"\[nodes.arm2\] node_id: missing"),
        (
            "[nodes.arm2]\nnode_id = 5\n",
            r"\[nodes.arm2\] node_id: expected a node-ID not used by \[nodes.arm\] \(5\), got 5",
        ),
        ("[nodes.Arm]\nnode_id = 9\n", r"\[nodes.Arm\]: expected a node name of lower-case letters"),
        (
            "[nodes.arm2]\nnode_id = 9\ncolour = 1\n",
            r"\[nodes.arm2\] colour: expected one of eds, node_id \(an unknown key\)",
        ),
        (
            "[nodes.arm2]\nnode_id = 200\n",
            r"\[nodes.arm2\] node_id: expected an integer in \[1, 127\], got 200",
        ),
    ],
)
def test_a_bad_other_node_is_refused_naming_the_field(tmp_path, extra, message):
    with pytest.raises(NetworkConfigError, match=message):
        load_network(network(tmp_path, NET + extra))


@pytest.fixture
def bench(tmp_path):
    """The arm (node 5, slave EDS on the device side, none in the network file) and the amplifier (node 6)."""
    nw = canopen.Network()
    nw.NOTIFIER_CYCLE = 0.05
    nw.connect(interface="virtual", channel="tt-other")
    devs = [
        Device(nw, nid, bc("slave.eds"), settings=DeviceSettings(heartbeat_producer_ms=50)) for nid in (5, 6)
    ]
    for d in devs:
        d.start()
    try:
        yield network(tmp_path)
    finally:
        for d in devs:
            d.close()
        nw.disconnect()


def test_the_cli_reaches_other_nodes(bench, cli):
    net = str(bench)
    code, out, err = cli("get", "amplifier", "T_sensor_C", "--network", net, "--timeout", "1")
    assert code == 0 and out.startswith("amplifier 0x2000 T_sensor_C"), err
    code, out, err = cli("get", "arm", "T_sensor_C", "--network", net, "--timeout", "1")
    assert code == 2 and "arm (node 5) has no EDS" in err and "telethermo sdo 5" in err
    code, out, err = cli("sdo", "arm", "0x1017:0", "--network", net, "--timeout", "1")
    assert code == 0 and "0x1017:00" in out, err
    code, out, err = cli("sdo", "7", "0x1017:0", "--network", net, "--timeout", "0.3")  # nobody at 7
    assert code == 1 and "node 7" in err
    code, out, err = cli("nmt", "preop", "arm", "--network", net)
    assert code == 0, err
    code, out, err = cli("status", "arm", "amplifier", "--network", net, "--timeout", "1")
    assert "arm (node 5): NMT PRE-OPERATIONAL" in out, out + err


@pytest.fixture
def bench_with_pair(bench):
    """The bench above plus our master (1) and slave (2) as real devices on the same virtual bus."""
    nw = canopen.Network()
    nw.NOTIFIER_CYCLE = 0.05
    nw.connect(interface="virtual", channel="tt-other")
    devs = {
        role: Device(nw, nid, bc(f"{role}.eds"), settings=DeviceSettings(heartbeat_producer_ms=50))
        for role, nid in (("master", 1), ("slave", 2))
    }
    for d in devs.values():
        d.start()
    try:
        yield bench, devs
    finally:
        for d in devs.values():
            d.close()
        nw.disconnect()


def test_mode_and_fault_reset_address_only_the_master_and_the_slave(bench_with_pair, cli):
    """Issue 25: a third device in network.toml (the docs suggest adding one) broke `mode` and `fault-reset`:
    they wrote `mode` to every node of the file. The amplifier's EDS has a `mode` object: it must not
    change."""
    net, devs = bench_with_pair
    amp = canopen.Network()
    amp.connect(interface="virtual", channel="tt-other")
    try:
        other = amp.add_node(6, str(bc("slave.eds")))  # canopen's own client, not ours
        other.sdo["mode"].raw = 1
        code, out, err = cli(
            "mode", "idle", "--network", str(net), "--bus", "virtual:tt-other", "--timeout", "1"
        )
        assert (code, err) == (0, ""), err
        assert out.splitlines() == ["slave (node 2): mode idle", "master (node 1): mode idle", "mode: idle"]
        assert other.sdo["mode"].raw == 1  # untouched
        code, out, err = cli(
            "fault-reset", "--network", str(net), "--bus", "virtual:tt-other", "--timeout", "1"
        )
        assert (code, err) == (0, ""), err
        assert [ln.split(":")[0] for ln in out.splitlines()] == ["master (node 1)", "slave (node 2)"]
    finally:
        amp.disconnect()


def test_status_of_an_absent_device_exits_1(bench, cli):
    """Issue 25: `status` of a device named in the file but absent from the bus exited 0 (no EDS: nothing
    read).
    Exit 1 like every node that does not answer; a present EDS-less device shows its 0x1000."""
    net = network(bench.parent, NET + "[nodes.ghost]\nnode_id = 9\n")
    code, out, err = cli(
        "status", "ghost", "--network", str(net), "--bus", "virtual:tt-other", "--timeout", "0.3"
    )
    assert code == 1, (out, err)
    # which bus was asked, so that a node on another channel or interface is found by the reader
    assert err == (
        "telethermo status: no SDO answer from ghost on virtual:tt-other (from --bus); "
        "are they on this bus (--bus, -i/-c)?\n"
    )
    assert "ghost (node 9) did not answer reading 0x1000 device type" in out
    code, out, err = cli("status", "arm", "--network", str(net), "--timeout", "1")
    assert code == 0 and "  device type     0x" in out, (out, err)
