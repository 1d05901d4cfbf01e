"""The device layer on a real SocketCAN interface (vcan0): the same CiA 301 behaviour as on the
python-can ``virtual`` bus, checked with canopen's client. Part of the ``vcan`` group: run natively
where the kernel has vcan, else inside ../shared/tools/vcan-run (scripts/run-tests does both)."""

from __future__ import annotations

import os
import struct

import can
import canopen
import pytest
from canopen import SdoAbortedError

from telethermo.bus_config import path
from telethermo.device import Device, DeviceSettings, NmtCommand, SyncProducer

pytestmark = pytest.mark.vcan


@pytest.fixture
def channel() -> str:
    name = os.environ.get("TELETHERMO_VCAN", "vcan0")
    if not os.path.exists(f"/sys/class/net/{name}"):
        pytest.skip(
            f"SocketCAN interface {name!r} does not exist on this kernel "
            "(set TELETHERMO_VCAN, or run inside ../shared/tools/vcan-run)"
        )
    return name


def test_device_on_socketcan(channel):
    nets = []

    def network() -> canopen.Network:
        net = canopen.Network()
        net.NOTIFIER_CYCLE = 0.05
        net.connect(interface="socketcan", channel=channel)
        nets.append(net)
        return net

    dev = None
    try:
        dev = Device(network(), 1, path("master.eds"), settings=DeviceSettings(known_node_ids=(1, 2)))
        dev.start()
        client = network()
        node = client.add_node(1, str(path("master.eds")))
        node.sdo.RESPONSE_TIMEOUT = 5.0  # the VM is slow; this is no timing assertion
        node.tpdo.read(from_od=True)
        node.sdo["kp_A_per_C"].raw = 2.5
        with pytest.raises(SdoAbortedError) as exc:
            node.sdo["T_max_C"].raw = 44.0
        assert exc.value.code == 0x06090031 and node.sdo["T_max_C"].raw == 43.0
        assert dev.read("kp_A_per_C") == 2.5
        node.nmt.state = "OPERATIONAL"
        node.sdo["mode"].raw  # barrier: the NMT frame was handled
        dev.write("estimate_C", 30.5)
        client.send_message(0x182, struct.pack("<ff", 29.0, -0.5))  # the slave's TPDO1 = our RPDO1
        client.sync.transmit(1)
        assert node.tpdo[1].wait_for_reception(10.0) is not None
        assert node.tpdo[1]["estimate_C"].raw == 30.5
        node.sdo["mode"].raw
        assert dev.read("peer_estimate_C") == 29.0 and dev.read("peer_Q_W") == -0.5
        client.send_message(0x7F0, b"\x01")
        node.sdo["mode"].raw
        assert node.sdo["unknown_cobid_frames"].raw == 1
        # the producer's own tick on SocketCAN: our SYNC, then our TPDO1
        listener = can.Bus(interface="socketcan", channel=channel)
        try:
            dev.nmt_command(NmtCommand.START, 1)
            SyncProducer(dev).transmit()
            ids = []
            while len(ids) < 3 and (m := listener.recv(10.0)) is not None:
                if m.arbitration_id != 0x701:  # heartbeats come from another thread, at any time
                    ids.append(m.arbitration_id)
            assert ids[:3] == [0x000, 0x080, 0x181]
        finally:
            listener.shutdown()
    finally:
        if dev is not None:
            dev.close()
        for net in nets:
            net.disconnect()
