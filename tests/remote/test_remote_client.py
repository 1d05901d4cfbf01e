"""The remote-node client (telethermo.remote) against a real CiA 301 device (telethermo.device.Device
over canopen's LocalNode, from the shipped master EDS) on a python-can virtual bus: SDO by EDS name, the
local range check, the node's refusals and silence, the TPDO remapping and its restoration, heartbeats."""

from __future__ import annotations

import itertools
import time

import canopen
import pytest

from telethermo.device.device import Device
from telethermo.device.netconfig import load_network
from telethermo.remote import pdo
from telethermo.remote.client import NodeClient
from telethermo.remote.errors import Failure, Refused, UserError
from telethermo.remote.heartbeat import heartbeat_wait_s, watch_heartbeats
from telethermo.remote.targets import Target, resolve_node

_n = itertools.count()


@pytest.fixture
def bus():
    """(client network, master Device, master Target, network settings) on a fresh virtual channel."""
    channel = f"tt-remote-{next(_n)}-{time.monotonic_ns()}"
    net = load_network()
    node_nw = canopen.Network()
    node_nw.NOTIFIER_CYCLE = 0.05
    node_nw.connect(interface="virtual", channel=channel)
    cfg = net.node("master")
    dev = Device(node_nw, cfg.node_id, cfg.eds, settings=net.device_settings("master"))
    dev.start()
    client_nw = canopen.Network()
    client_nw.connect(interface="virtual", channel=channel)
    try:
        yield client_nw, dev, resolve_node(net, "master"), net
    finally:
        client_nw.disconnect()
        dev.close()
        node_nw.disconnect()


def test_reads_and_writes_by_eds_name_and_number(bus):
    nw, dev, target, _ = bus
    c = NodeClient(nw, target, timeout_s=1.0)
    assert c.get("kp_A_per_C") == pytest.approx(dev.read("kp_A_per_C"))
    c.set("kp_A_per_C", 2.5)
    assert dev.read("kp_A_per_C") == pytest.approx(2.5)
    assert c.get((0x1018, 1)) == c.get("Identity object.Vendor-ID") == dev.read((0x1018, 1))


def test_out_of_range_is_refused_locally_and_nothing_is_sent(bus):
    nw, dev, target, _ = bus
    c = NodeClient(nw, target, timeout_s=1.0)
    before = dev.read("kp_A_per_C")
    with pytest.raises(UserError, match="out of range"):
        c.set("kp_A_per_C", 500.0)
    assert dev.read("kp_A_per_C") == before
    with pytest.raises(UserError, match="kp_A_per_"):  # an unknown name: suggestions
        c.info("kp")


def test_a_refusal_carries_the_abort_code_and_a_silent_node_says_so(bus):
    nw, _, target, _ = bus
    c = NodeClient(nw, target, timeout_s=1.0)
    with pytest.raises(Refused) as e:
        c.write(c.info("T_sensor_C"), 1.0)  # read-only: the node refuses, not the client
    assert e.value.code == 0x06010002 and "0x06010002" in str(e.value)
    silent = NodeClient(nw, Target("nobody", 5, target.eds), timeout_s=0.1)
    with pytest.raises(Failure, match="did not answer"):
        silent.get("kp_A_per_C")


def test_writes_follow_cia301_remapping_order():
    saved = pdo.TpdoSettings(0x1801, 0x1A01, 0x281, 10, (0x20000020, 0x20020020))
    new = pdo.remapped(saved, [0x28070020, 0x20010020], transmission_type=1)
    assert pdo.configure_writes(new) == [
        (0x1801, 1, 0x281 | pdo.PDO_INVALID),
        (0x1A01, 0, 0),
        (0x1A01, 1, 0x28070020),
        (0x1A01, 2, 0x20010020),
        (0x1A01, 0, 2),
        (0x1801, 2, 1),
        (0x1801, 1, 0x281),
    ]
    assert (
        pdo.remapped(pdo.TpdoSettings(0x1801, 0x1A01, 0x281 | pdo.PDO_INVALID, 10, ()), [], 1).cob_id == 0x281
    )


def test_a_tpdo_remapped_on_the_node_and_put_back(bus):
    nw, dev, target, _ = bus
    c = NodeClient(nw, target, timeout_s=1.0)
    saved = pdo.read_tpdo(c, 0x1801, 0x1A01)
    pdo.configure(c, pdo.remapped(saved, [0x28070020, 0x20000020], transmission_type=1))
    assert pdo.read_tpdo(c, 0x1801, 0x1A01) == pdo.TpdoSettings(
        0x1801, 0x1A01, saved.cob_id & ~pdo.PDO_INVALID, 1, (0x28070020, 0x20000020)
    )
    pdo.configure(c, saved)
    assert pdo.read_tpdo(c, 0x1801, 0x1A01) == saved
    assert dev.read((0x1A01, 0)) == len(saved.entries)


def test_heartbeat_watch_hears_the_node_and_its_state(bus):
    nw, _, target, net = bus
    hb = watch_heartbeats(nw)
    assert hb.wait_for(lambda: target.node_id in hb.last, heartbeat_wait_s(net) + 1.0)
    assert hb.state_name(target.node_id) == "PRE-OPERATIONAL" and hb.state_name(99) == "unknown"
