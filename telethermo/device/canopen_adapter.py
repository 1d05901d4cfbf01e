"""Every use of canopen's private state by the device layer, in one module (written against canopen 2.4).

The device builds on ``canopen.LocalNode`` (object dictionary, data store, SDO server for expedited
and segmented transfers) and replaces or watches parts of it that canopen keeps private:

- :class:`GatedLocalNode`: ``LocalNode.set_data`` and ``LocalNode._find_object`` overridden, so that
  every SDO write goes through the device (checks, side effects) and a sub-index the EDS does not
  have is refused as CiA 301 says;
- :func:`set_nmt_state`: ``NmtSlave._state`` kept equal to the device's NMT state;
- :func:`prime_sdo_abort` and :func:`sdo_buffer`: ``SdoServer._index``/``_subindex``/``_buffer``,
  read to track segmented transfers (canopen's server keeps no transfer state);
- :func:`detach_default_handlers`, :func:`listen_first`, :func:`stop_listening`: LocalNode's own NMT
  and SDO subscriptions replaced by gated ones; a listener put before canopen's dispatcher.

A canopen upgrade that changes any of these breaks this file only.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable, Collection, cast

import can
import canopen
from canopen import objectdictionary as odmod
from canopen import SdoAbortedError
from canopen.sdo.server import SdoServer

from telethermo.cia301 import ABORT_LENGTH, ABORT_NO_SUBINDEX, ABORT_READ_ONLY

#: ``write(var, data)``: the device's check-store-apply path of one SDO write
WriteHook = Callable[[odmod.ODVariable, bytes], None]


class GatedLocalNode(canopen.LocalNode):
    """LocalNode whose SDO writes go through ``write`` (checks, side effects) before storing, and
    which knows only the (index, sub-index) pairs in ``known`` (the EDS's variables)."""

    def __init__(
        self, node_id: int, eds: str | Path, *, write: WriteHook, known: Collection[tuple[int, int]]
    ):
        super().__init__(node_id, canopen.import_od(str(eds), node_id))
        self._gate_write = write
        self._gate_known = known

    def set_data(self, index: int, subindex: int, data: bytes, check_writable: bool = False) -> None:
        obj = self._find_object(index, subindex)
        if check_writable and not obj.writable:
            raise SdoAbortedError(ABORT_READ_ONLY)
        if (obj.data_type in odmod.NUMBER_TYPES and 8 * len(data) != len(obj)) or (
            obj.data_type == odmod.BOOLEAN and len(data) != 1
        ):
            raise SdoAbortedError(ABORT_LENGTH)
        self._gate_write(obj, bytes(data))

    def _find_object(self, index: int, subindex: int) -> odmod.ODVariable:
        # canopen leaves it unannotated, and mypy's untyped_calls_exclude does not reach a super() call
        obj = super()._find_object(index, subindex)  # type: ignore[no-untyped-call]
        # canopen invents ARRAY entries past the last one and ignores the sub-index of a VAR
        if obj.subindex != subindex or (index, subindex) not in self._gate_known:
            raise SdoAbortedError(ABORT_NO_SUBINDEX)
        return cast(odmod.ODVariable, obj)

    def find(self, index: int, subindex: int) -> odmod.ODVariable:
        """The variable at index:subindex; SdoAbortedError 0x06020000 / 0x06090011 if there is none."""
        return self._find_object(index, subindex)


def set_nmt_state(node: canopen.LocalNode, code: int) -> None:
    """Keep canopen's NmtSlave state (heartbeat code) equal to the device's."""
    node.nmt._state = code


def prime_sdo_abort(sdo: SdoServer) -> None:
    """canopen's server packs ``_index``/``_subindex`` into its abort frame: None before the first
    transfer made an invalid first request (e.g. command specifier 7) raise instead of abort."""
    if sdo._index is None:
        sdo._index, sdo._subindex = 0, 0


def sdo_buffer(sdo: SdoServer) -> bytearray | None:
    """The segmented-transfer buffer of canopen's SDO server (None or empty when none is open)."""
    return cast("bytearray | None", sdo._buffer)


def detach_default_handlers(network: canopen.Network, node: canopen.LocalNode) -> None:
    """Remove the NMT and SDO handlers LocalNode subscribed when it joined ``network``."""
    network.unsubscribe(0, node.nmt.on_command)
    network.unsubscribe(node.sdo.rx_cobid, node.sdo.on_request)


def listen_first(network: canopen.Network, listener: can.Listener) -> None:
    """Put ``listener`` before canopen's own dispatcher, so that it sees each frame first."""
    if network.notifier is not None:
        network.notifier.listeners.insert(0, listener)
    else:
        # canopen's attribute is inferred as list[MessageListener]; the Notifier takes any can.Listener
        cast("list[can.Listener]", network.listeners).insert(0, listener)


def stop_listening(network: canopen.Network, listener: can.Listener) -> None:
    """Undo :func:`listen_first` (a listener not there is no error)."""
    if network.notifier is not None:
        try:
            network.notifier.remove_listener(listener)
        except ValueError:
            pass
    if listener in network.listeners:
        network.listeners.remove(listener)
