"""NMT slave behaviour against canopen's NMT master: boot-up and heartbeat on every path, PDOs only
in OPERATIONAL, SDO in PRE-OPERATIONAL and OPERATIONAL only, resets restore the power-on values."""

from __future__ import annotations

import threading
import time

import can
import pytest
from canopen.sdo import SdoCommunicationError

from telethermo.device import DeviceSettings, NmtCommand, NmtState
from telethermo.nodes.launch import wait_for

FAST_HB = DeviceSettings(heartbeat_producer_ms=20)


def wait_state(node, want: str, timeout: float = 2.0) -> str:
    """Heartbeats until the remote node reports ``want`` (canopen's NmtMaster decodes them)."""
    end = time.monotonic() + timeout
    state = None
    while time.monotonic() < end:
        state = node.nmt.wait_for_heartbeat(timeout)
        if state == want:
            return state
    return state


def pdo_after_sync(lab, client_net, bus, cob_id: int = 0x181, counter: int = 1, timeout: float = 0.3):
    """TPDO1 answering one SYNC (None if none within ``timeout``: 0.3 s for "no PDO", 2 s when one is due)."""
    while bus.recv(0) is not None:
        pass
    client_net.sync.transmit(counter)
    return lab.recv_until(bus, lambda m: m.arbitration_id == cob_id, timeout)


def test_power_on_sends_bootup_then_heartbeats_in_pre_operational(lab):
    bus = lab.raw_bus()
    dev = lab.device("master", start=False, settings=FAST_HB)
    assert dev.state is NmtState.INITIALISING
    dev.start()
    boot = lab.recv_until(bus, lambda m: m.arbitration_id == 0x701)
    assert boot is not None and list(boot.data) == [0x00]
    hb = lab.recv_until(bus, lambda m: m.arbitration_id == 0x701)
    assert hb is not None and list(hb.data) == [0x7F]
    assert dev.state is NmtState.PRE_OPERATIONAL


def test_an_sdo_request_answering_the_bootup_is_served_however_late_the_booting_thread_runs(lab):
    """A client that reads the node as soon as its boot-up arrives: the request reaches the notifier thread
    while the thread that sent the boot-up may not have run one more line (a loaded machine). The booting
    thread is held here for 0.3 s right after the boot-up leaves; the request must still be answered."""
    dev = lab.device("master", start=False, settings=FAST_HB)
    node = lab.client("master")
    node.sdo.RESPONSE_TIMEOUT = 3.0
    send = dev.core.send

    def send_then_stall(cob_id: int, data: bytes) -> None:
        send(cob_id, data)
        if cob_id == 0x701 and bytes(data) == b"\x00":
            time.sleep(0.3)  # the booting thread descheduled right after the boot-up

    answered: list = []

    def on_bootup(can_id: int, data: bytearray, timestamp: float) -> None:
        if bytes(data) == b"\x00":  # read from a thread of the client's, as a tool reacting to the boot-up
            threading.Thread(target=lambda: answered.append(node.sdo["kp_A_per_C"].raw), daemon=True).start()

    node.network.subscribe(0x701, on_bootup)
    dev.core.send = send_then_stall
    dev.start()
    assert wait_for(lambda: answered, 5.0), "the SDO request sent on the boot-up was never answered"
    assert answered == [pytest.approx(0.5)] and dev.state is NmtState.PRE_OPERATIONAL


def test_pdos_only_in_operational_and_sdo_not_in_stopped(lab):
    dev = lab.device("master", settings=FAST_HB)
    node = lab.client("master")
    bus = lab.raw_bus()
    net = node.network
    assert pdo_after_sync(lab, net, bus) is None  # PRE-OPERATIONAL: no PDO ...
    assert node.sdo["kp_A_per_C"].raw == pytest.approx(0.5)  # ... but SDO works
    node.nmt.state = "OPERATIONAL"
    assert wait_state(node, "OPERATIONAL") == "OPERATIONAL"
    assert pdo_after_sync(lab, net, bus, counter=2, timeout=2.0) is not None
    node.nmt.state = "STOPPED"
    assert wait_state(node, "STOPPED") == "STOPPED"
    assert dev.state is NmtState.STOPPED
    assert pdo_after_sync(lab, net, bus, counter=3) is None
    node.sdo.RESPONSE_TIMEOUT = 0.2
    with pytest.raises(SdoCommunicationError):
        node.sdo["kp_A_per_C"].raw  # no SDO in STOPPED
    node.nmt.state = "PRE-OPERATIONAL"
    assert wait_state(node, "PRE-OPERATIONAL") == "PRE-OPERATIONAL"
    assert pdo_after_sync(lab, net, bus, counter=4) is None
    assert node.sdo["kp_A_per_C"].raw == pytest.approx(0.5)
    node.nmt.state = "OPERATIONAL"  # STOPPED -> ... -> OPERATIONAL again
    assert wait_state(node, "OPERATIONAL") == "OPERATIONAL"
    assert pdo_after_sync(lab, net, bus, counter=5, timeout=2.0) is not None


def test_reset_node_restores_everything_and_boots(lab):
    dev = lab.device("slave", settings=FAST_HB)
    node = lab.client("slave")
    node.sdo["kp_A_per_C"].raw = 3.0
    node.sdo["Producer heartbeat time"].raw = 30
    node.nmt.state = "OPERATIONAL"
    assert wait_state(node, "OPERATIONAL") == "OPERATIONAL"
    node.nmt.state = "RESET"
    node.nmt.wait_for_bootup(2.0)
    assert wait_state(node, "PRE-OPERATIONAL") == "PRE-OPERATIONAL"
    assert node.sdo["kp_A_per_C"].raw == pytest.approx(0.5)  # application reset
    assert node.sdo["Producer heartbeat time"].raw == 20  # power-on value (settings), not the EDS 100
    assert dev.state is NmtState.PRE_OPERATIONAL


def test_reset_communication_restores_only_communication_objects(lab):
    lab.device("slave", settings=FAST_HB)
    node = lab.client("slave")
    node.sdo["kp_A_per_C"].raw = 3.0
    node.sdo["Producer heartbeat time"].raw = 30
    node.nmt.state = "RESET COMMUNICATION"
    node.nmt.wait_for_bootup(2.0)
    assert node.sdo["Producer heartbeat time"].raw == 20
    assert node.sdo["kp_A_per_C"].raw == pytest.approx(3.0)


def test_heartbeat_carries_the_state_on_every_path(lab):
    dev = lab.device("master", settings=FAST_HB)
    bus = lab.raw_bus()
    for command, code in (
        (NmtCommand.START, 5),
        (NmtCommand.STOP, 4),
        (NmtCommand.ENTER_PRE_OPERATIONAL, 127),
        (NmtCommand.START, 5),
        (NmtCommand.RESET_COMMUNICATION, 127),
        (NmtCommand.STOP, 4),
        (NmtCommand.RESET_NODE, 127),
    ):
        bus.send(can.Message(arbitration_id=0, data=[command, 1], is_extended_id=False))
        if command in (NmtCommand.RESET_NODE, NmtCommand.RESET_COMMUNICATION):
            boot = lab.recv_until(bus, lambda m: m.arbitration_id == 0x701 and list(m.data) == [0])
            assert boot is not None, command
        hb = lab.recv_until(bus, lambda m: m.arbitration_id == 0x701 and list(m.data) == [code])
        assert hb is not None, (command, code)
    assert dev.state is NmtState.PRE_OPERATIONAL


def test_commands_for_other_nodes_are_ignored_and_broadcast_applies(lab):
    dev = lab.device("master", settings=FAST_HB)
    node1 = lab.client("master")
    node2 = node1.network.add_node(2)  # an NMT master addressing node 2 (absent)
    node2.nmt.state = "OPERATIONAL"
    node1.sdo["mode"].raw  # an SDO round trip: frames are handled in order, so the NMT frame was seen
    assert dev.state is NmtState.PRE_OPERATIONAL
    node1.network.nmt.state = "OPERATIONAL"  # broadcast (node-ID 0)
    assert wait_for(lambda: dev.state is NmtState.OPERATIONAL, 10.0, poll_s=0.01)


def test_local_nmt_command_applies_to_self_and_is_sent(lab):
    """A node never receives its own frames: nmt_command() both sends and applies."""
    dev = lab.device("master", settings=FAST_HB)
    bus = lab.raw_bus()
    dev.nmt_command(NmtCommand.START, 0)
    frame = lab.recv_until(bus, lambda m: m.arbitration_id == 0)
    assert frame is not None and list(frame.data) == [1, 0]
    assert dev.state is NmtState.OPERATIONAL


def test_configuration_written_before_start_survives_power_on_but_not_reset_node(lab):
    dev = lab.device("master", start=False, settings=FAST_HB)
    dev.write("kp_A_per_C", 1.75)
    dev.write("mode", 2)
    dev.start()
    node = lab.client("master")
    assert node.sdo["kp_A_per_C"].raw == 1.75 and node.sdo["mode"].raw == 2
    resets = []
    dev.add_nmt_listener(lambda old, new, cmd: resets.append((old, new, cmd)))
    node.nmt.state = "RESET"
    node.nmt.wait_for_bootup(2.0)
    assert node.sdo["kp_A_per_C"].raw == 0.5 and node.sdo["mode"].raw == 0
    assert resets == [
        (NmtState.PRE_OPERATIONAL, NmtState.INITIALISING, NmtCommand.RESET_NODE),
        (NmtState.INITIALISING, NmtState.PRE_OPERATIONAL, NmtCommand.RESET_NODE),
    ]
