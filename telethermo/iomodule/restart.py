"""The controller as NMT master of its I/O modules (CiA 302 habit): a module that lost our heartbeat cut the
drive and, per its 0x1029, went to PRE-OPERATIONAL; nothing in CiA 301 starts it again. When a module's
heartbeat reports PRE-OPERATIONAL (or a boot-up) while the controller is OPERATIONAL and its own link is
healthy, the controller re-checks the module's commissioning by SDO (every value it wrote at start-up read
back, among them 0x6443:1 = substitute and 0x6444:1 = the code of 0 A; a module that forgot them, e.g. after a
reset, is commissioned again) and sends it NMT START; the restart is counted and logged in one line. A module
another NMT master put into PRE-OPERATIONAL or STOPPED (its command seen on the bus, addressed to the module
or to all nodes: the SYNC producer's end of a session) is held: it is not started again until a START or a
reset for it is seen.

:func:`module_action` is the decision (pure: the module's state seen, the controller's state -> action);
:class:`ModuleSupervisor` carries it out (the heartbeat subscription on the driver's own network, a worker
thread for the SDO and NMT traffic, which must not run on the network's receive thread).
"""

from __future__ import annotations

import enum
import logging
import queue
import threading
import time
from collections.abc import Callable

import canopen

from telethermo.iomodule.commission import CommissionError, ModuleSetup, commission

log = logging.getLogger("telethermo.iorig")

#: NMT states a heartbeat reports (CiA 301 7.2.8.3.2.1)
BOOTUP, STOPPED, OPERATIONAL, PRE_OPERATIONAL = 0x00, 0x04, 0x05, 0x7F
#: a restart that did not bring the module to OPERATIONAL is tried again after this long, s
RETRY_S = 1.0


class ModuleAction(enum.Enum):
    """What a module's heartbeat asks the controller to do."""

    NONE = "none"
    RESTART = "restart"
    """Re-check the commissioning, then NMT START."""


#: NMT commands (CiA 301 7.2.8.3.1) that hold a module where another NMT master put it, and those that
#: end the hold
HOLDING_COMMANDS = (0x02, 0x80)
RELEASING_COMMANDS = (0x01, 0x81, 0x82)


def module_action(
    module_state: int, *, own_operational: bool, link_ok: bool, restart_due: bool, held: bool = False
) -> ModuleAction:
    """The action for a heartbeat of one module reporting ``module_state`` (its NMT state code), given whether
    this controller is OPERATIONAL, whether its own bus link is healthy, whether a restart of that module is
    due (none in flight, or the last one older than :data:`RETRY_S`), and whether another NMT master's
    command holds the module (PRE-OPERATIONAL or STOPPED on purpose). A STOPPED module was stopped on
    purpose as well: it is left alone."""
    if module_state not in (BOOTUP, PRE_OPERATIONAL):
        return ModuleAction.NONE
    if held or not (own_operational and link_ok and restart_due):
        return ModuleAction.NONE
    return ModuleAction.RESTART


def check_commissioning(node: canopen.RemoteNode, setup: ModuleSetup) -> list[tuple[int, int, int, int]]:
    """Every value commissioning wrote, read back by SDO: the (index, sub, written, read) that differ (empty:
    the module still holds its commissioning). Raises canopen.SdoCommunicationError/SdoAbortedError."""
    final = {(i, s): v for i, s, v in setup.writes()}
    wrong = []
    for (index, sub), value in final.items():
        obj = node.object_dictionary[index]
        var = obj if isinstance(obj, canopen.objectdictionary.ODVariable) else obj[sub]
        got = int(var.decode_raw(node.sdo.upload(index, sub)))
        if got != value:
            wrong.append((index, sub, value, got))
    return wrong


class ModuleSupervisor:
    """Watches the heartbeats of ``nodes`` (name -> RemoteNode, with their ``setups`` by node-ID) on
    ``network`` and restarts a module that reports PRE-OPERATIONAL or a boot-up while ``controller_ok()``
    (this controller OPERATIONAL and its link healthy). :meth:`start` / :meth:`stop`; :attr:`restarts` counts
    the NMT STARTs sent, :attr:`failures` the re-checks that could not be completed (module left alone)."""

    def __init__(
        self,
        network: canopen.Network,
        nodes: dict[str, canopen.RemoteNode],
        setups: dict[int, ModuleSetup],
        *,
        source: str = "",
    ) -> None:
        self.network = network
        self.nodes = {node.id: (name, node) for name, node in nodes.items()}
        self.setups = setups
        self.source = source
        self.controller_ok: Callable[[], tuple[bool, bool]] = lambda: (False, False)
        """() -> (this controller OPERATIONAL, its own bus link healthy); set by the node program. Until it
        is set nothing is restarted."""
        self.restarts = 0
        self.failures = 0
        self._last_try: dict[int, float] = {}
        self._in_flight: set[int] = set()
        self._held: set[int] = set()
        self._lock = threading.Lock()
        self._jobs: queue.Queue[int | None] = queue.Queue()
        self._worker: threading.Thread | None = None

    def start(self) -> None:
        for node_id in self.nodes:
            self.network.subscribe(0x700 + node_id, self._on_heartbeat)
        self.network.subscribe(0x000, self._on_nmt_command)
        self._worker = threading.Thread(target=self._run, name="io-module-restart", daemon=True)
        self._worker.start()

    def stop(self) -> None:
        """No more restarts (before the node puts its modules into PRE-OPERATIONAL at the end)."""
        for node_id in self.nodes:
            self.network.unsubscribe(0x700 + node_id, self._on_heartbeat)
        self.network.unsubscribe(0x000, self._on_nmt_command)
        if self._worker is not None:
            self._jobs.put(None)
            self._worker.join(timeout=10.0)
            self._worker = None

    def _on_nmt_command(self, cob: int, data: bytearray, timestamp: float) -> None:
        """Another NMT master's command (ours are not received back): PRE-OPERATIONAL or STOP holds the
        modules it addresses, START or a reset releases them."""
        if len(data) != 2:
            return
        command, target = data[0], data[1]
        with self._lock:
            for node_id in self.nodes if target == 0 else [target] if target in self.nodes else []:
                if command in HOLDING_COMMANDS:
                    self._held.add(node_id)
                elif command in RELEASING_COMMANDS:
                    self._held.discard(node_id)

    def _on_heartbeat(self, cob: int, data: bytearray, timestamp: float) -> None:
        if not data:
            return
        node_id, state = cob - 0x700, data[0] & 0x7F
        operational, link_ok = self.controller_ok()
        now = time.monotonic()
        with self._lock:
            if state == OPERATIONAL:
                self._last_try.pop(node_id, None)
            due = node_id not in self._in_flight and now - self._last_try.get(node_id, -1e9) >= RETRY_S
            act = module_action(
                state,
                own_operational=operational,
                link_ok=link_ok,
                restart_due=due,
                held=node_id in self._held,
            )
            if act is ModuleAction.RESTART:
                self._in_flight.add(node_id)
                self._last_try[node_id] = now
        if act is ModuleAction.RESTART:
            self._jobs.put(node_id)

    def _run(self) -> None:
        while (node_id := self._jobs.get()) is not None:
            try:
                self._restart(node_id)
            finally:
                with self._lock:
                    self._in_flight.discard(node_id)

    def _restart(self, node_id: int) -> None:
        name, node = self.nodes[node_id]
        setup = self.setups[node_id]
        try:
            wrong = check_commissioning(node, setup)
            if wrong:
                commission(node, setup)
        except (canopen.SdoCommunicationError, canopen.SdoAbortedError, CommissionError) as exc:
            self.failures += 1
            log.warning(
                "%s: io module %d (%s) not restarted: commissioning check failed: %s",
                self.source,
                node_id,
                name,
                exc,
            )
            return
        operational, link_ok = self.controller_ok()
        with self._lock:
            held = node_id in self._held
        if held or not (operational and link_ok):  # held meanwhile, or we left OPERATIONAL: leave it
            return
        node.nmt.send_command(0x01)
        self.restarts += 1
        again = (
            f"commissioned again ({len(wrong)} value(s) had changed, e.g. 0x{wrong[0][0]:04X}:{wrong[0][1]})"
            if wrong
            else "commissioning intact (substitute 0x6444:1 = the code of 0 A)"
        )
        log.warning(
            "%s: io module %d (%s) was not OPERATIONAL while we are: %s, NMT START sent (restart %d)",
            self.source,
            node_id,
            name,
            again,
            self.restarts,
        )
