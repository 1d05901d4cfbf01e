"""The controller restarts an I/O module that left OPERATIONAL while it runs (issue 24, robustness;
telethermo/iomodule/restart.py): the decision as a table, and the driver against a real module process on the
hub, the NMT commands sent by the test's own canopen client (a third NMT master) and the module's state read
from its heartbeat and by SDO from its EDS."""

from __future__ import annotations

import pytest

from telethermo.bus_config import path as bus_config_path
from telethermo.iomodule.iorig import IoRig
from telethermo.iomodule.restart import (
    BOOTUP,
    OPERATIONAL,
    PRE_OPERATIONAL,
    STOPPED,
    ModuleAction,
    module_action,
)
from telethermo.iomodule.rigconfig import load_rig_config
from telethermo.transport.bus import parse_bus_string
from tests.iomodule.helpers import CONTROLLER_ID, MODULE_ID

RESTART, NONE = ModuleAction.RESTART, ModuleAction.NONE


@pytest.mark.parametrize(
    "state, operational, link_ok, due, held, expected",
    [
        (PRE_OPERATIONAL, True, True, True, False, RESTART),  # lost us, went PRE-OPERATIONAL (0x1029 = 0)
        (BOOTUP, True, True, True, False, RESTART),  # reset: it boots with its defaults
        (OPERATIONAL, True, True, True, False, NONE),
        (STOPPED, True, True, True, False, NONE),  # stopped on purpose
        (PRE_OPERATIONAL, False, True, True, False, NONE),  # we are not OPERATIONAL: no control, no start
        (PRE_OPERATIONAL, True, False, True, False, NONE),  # our link is down: it would lose us again
        (PRE_OPERATIONAL, True, True, False, False, NONE),  # a restart is in flight / just tried
        (PRE_OPERATIONAL, True, True, True, True, NONE),  # another NMT master put it there
    ],
)
def test_module_action_table(state, operational, link_ok, due, held, expected):
    got = module_action(state, own_operational=operational, link_ok=link_ok, restart_due=due, held=held)
    assert got is expected


def _rig(hub) -> IoRig:
    cfg = load_rig_config(bus_config_path("rig_io_sim.toml"))
    transport = parse_bus_string(f"socketcand://127.0.0.1:{hub.port}/vcan0")
    return IoRig(cfg, transport=transport, controller_id=CONTROLLER_ID, period_s=0.01, lockstep=True)


def _states_since(bus, k: int) -> list[int]:
    return [s for _, n, s, _ in bus.heartbeats[k:] if n == MODULE_ID]


@pytest.mark.slow
def test_a_reset_module_is_commissioned_again_and_started(rig):
    """A module reset by someone (NMT RESET NODE from the test) boots with its defaults (400 ms sampling,
    output error mode "hold"): the controller finds them, commissions it again and starts it."""
    hub, bus, _ = rig
    io = _rig(hub).start()
    try:
        io.watch_controller(lambda: (True, True))
        bus.wait(lambda: bus.module_state() == OPERATIONAL)
        k = len(bus.heartbeats)
        bus.network.nmt.send_command(0x81)  # RESET NODE, to all nodes (the module is the only one)
        bus.wait(lambda: BOOTUP in _states_since(bus, k))
        boot = k + [n == MODULE_ID and s == BOOTUP for _, n, s, _ in bus.heartbeats[k:]].index(True)
        bus.wait(lambda: OPERATIONAL in _states_since(bus, boot), timeout_s=30)
        bus.wait(lambda: io.module_restarts >= 1, timeout_s=10)
        assert io.module_restarts == 1 and io.supervisor.failures == 0
        bus.sdo_settled()
        node = bus.node  # what the controller wrote again, read by the test's own client
        assert node.sdo[0x2100].raw == 10 and node.sdo[0x6443][1].raw == 1 and node.sdo[0x6444][1].raw == 0
        assert node.sdo[0x1016][1].raw == (CONTROLLER_ID << 16) | 150
    finally:
        io.close()


@pytest.mark.slow
def test_a_module_put_into_pre_operational_by_another_master_or_while_we_do_not_run_is_left_alone(rig):
    hub, bus, _ = rig
    io = _rig(hub).start()
    state = {"ok": (False, True)}
    try:
        io.watch_controller(lambda: state["ok"])
        bus.wait(lambda: bus.module_state() == OPERATIONAL)
        # we are not OPERATIONAL: a module that reports PRE-OPERATIONAL is not started
        k = len(bus.heartbeats)
        bus.network.nmt.send_command(0x81)  # reset: boot-up, then PRE-OPERATIONAL heartbeats
        bus.wait(lambda: _states_since(bus, k).count(PRE_OPERATIONAL) >= 5, timeout_s=30)
        assert io.module_restarts == 0 and OPERATIONAL not in _states_since(bus, k)
        # another NMT master holds it in PRE-OPERATIONAL: not started, although we run now. We run only once
        # the controller has taken the command in: until then the module's PRE-OPERATIONAL heartbeats (of
        # the reset above) are due for a restart, and one that came between "we run" and the command would
        # start it (a loaded machine delays the command's way through the hub to the controller). The
        # controller's network calls its subscribers in turn: ours, subscribed after the supervisor's, runs
        # after the supervisor has seen the command
        seen = []
        io.supervisor.network.subscribe(0x000, lambda cob, data, ts: seen.append(bytes(data)))
        bus.network.nmt.send_command(0x80)
        bus.wait(lambda: bytes([0x80, 0]) in seen)
        state["ok"] = (True, True)
        k = len(bus.heartbeats)
        bus.wait(lambda: _states_since(bus, k).count(PRE_OPERATIONAL) >= 5, timeout_s=30)
        assert io.module_restarts == 0 and OPERATIONAL not in _states_since(bus, k)
        # its START releases the hold; a later loss of OPERATIONAL (here: a reset) is ours to repair
        bus.network.nmt.send_command(0x01)
        bus.wait(lambda: bus.module_state() == OPERATIONAL)
        k = len(bus.heartbeats)
        bus.network.nmt.send_command(0x81)
        bus.wait(lambda: BOOTUP in _states_since(bus, k))
        bus.wait(lambda: io.module_restarts == 1, timeout_s=30)
        bus.wait(lambda: bus.module_state() == OPERATIONAL)
    finally:
        io.close()
