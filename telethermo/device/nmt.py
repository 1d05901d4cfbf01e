"""NMT slave of a device: INITIALISING → boot-up → PRE-OPERATIONAL on power-on, reset node and reset
communication; start / stop / enter pre-operational from NMT frames (COB-ID 0) or from the device's
own NMT master commands (a node never receives its own frames)."""

from __future__ import annotations

from typing import Callable

from telethermo.device import canopen_adapter as adapter
from telethermo.device.context import DeviceCore, NmtCommand, NmtState

#: ``fn(old, new, command)`` on every NMT state change (command None on power-on)
NmtListener = Callable[[NmtState, NmtState, "int | None"], None]
#: the command specifiers this slave knows (IntEnum members compare equal to their bytes)
COMMANDS = frozenset(NmtCommand)


class NmtSlave:
    """The NMT state machine; what each transition does to the other services is the device's
    ``reset(whole)`` (before the boot-up), ``booted()`` (after it) and ``changed(old, new)``."""

    def __init__(
        self,
        core: DeviceCore,
        *,
        reset: Callable[[bool | None], None],
        booted: Callable[[], None],
        changed: Callable[[NmtState, NmtState], None],
    ):
        self.core = core
        self.listeners: list[NmtListener] = []
        self._reset = reset
        self._booted = booted
        self._changed = changed

    def boot(self, *, whole: bool | None, command: int | None) -> None:
        """INITIALISING → boot-up → PRE-OPERATIONAL. ``whole``: True reset node (every object back to
        its power-on value), False reset communication (0x1000..0x1FFF), None power-on (keep the OD)."""
        core = self.core
        old = core.state
        core.state = NmtState.INITIALISING
        adapter.set_nmt_state(core.node, 0)
        self._reset(whole)
        if old is not NmtState.INITIALISING:
            core.call(self.listeners, old, NmtState.INITIALISING, command)
        # PRE-OPERATIONAL before the boot-up goes out: a client that answers the boot-up with an SDO request
        # (the notifier thread checks the state without the lock) must find the server serving, however late
        # this thread runs after the send; the listeners still hear of it after the boot-up, as before
        core.state = NmtState.PRE_OPERATIONAL
        adapter.set_nmt_state(core.node, int(NmtState.PRE_OPERATIONAL))
        core.send(0x700 + core.node_id, b"\x00")  # boot-up
        self.set_state(NmtState.PRE_OPERATIONAL, command, old=NmtState.INITIALISING)
        self._booted()

    def power_off(self) -> None:
        """``close()``: INITIALISING without a listener call."""
        self.core.state = NmtState.INITIALISING
        adapter.set_nmt_state(self.core.node, 0)

    def command(self, command: int, node_id: int = 0) -> None:
        """Send an NMT command on the bus (as NMT master) and apply it here if it targets this node."""
        command = int(command)
        if command not in COMMANDS:
            raise ValueError(f"unknown NMT command 0x{command:02X}")
        self.core.send(0x000, bytes([command, node_id]))
        if node_id in (0, self.core.node_id):
            self.apply(command)

    def on_frame(self, can_id: int, data: bytes | bytearray, timestamp: float) -> None:
        core = self.core
        if core.extended:
            return  # a 29-bit ID is no service of ours (counted as unknown)
        if len(data) != 2:
            core.stats.malformed_frames += 1
            return
        command, target = data[0], data[1]
        if target not in (0, core.node_id):
            return
        if command not in COMMANDS:
            core.stats.malformed_frames += 1
            return
        self.apply(command)

    def apply(self, command: int) -> None:
        core = self.core
        if not core.running:
            return
        with core.lock:
            if command == NmtCommand.RESET_NODE:
                self.boot(whole=True, command=command)
            elif command == NmtCommand.RESET_COMMUNICATION:
                self.boot(whole=False, command=command)
            elif command == NmtCommand.START:
                self.set_state(NmtState.OPERATIONAL, command)
            elif command == NmtCommand.STOP:
                self.set_state(NmtState.STOPPED, command)
            elif command == NmtCommand.ENTER_PRE_OPERATIONAL:
                self.set_state(NmtState.PRE_OPERATIONAL, command)

    def set_state(self, new: NmtState, command: int | None, old: NmtState | None = None) -> None:
        core = self.core
        old = core.state if old is None else old
        core.state = new
        adapter.set_nmt_state(core.node, int(new))
        self._changed(old, new)
        if new != old or command is not None:
            core.call(self.listeners, old, new, command)
