"""One remote node's objects by SDO, by their EDS name, with one-line failures.

:class:`NodeClient` wraps a canopen ``RemoteNode`` whose object dictionary stays empty: objects are
addressed by index and subindex from the node's EDS as :mod:`telethermo.remote.targets` parsed it (once
per file), so canopen need not parse the EDS again. Reads decode by the EDS type
(:mod:`telethermo.remote.codec`); a refusal raises :class:`~telethermo.remote.errors.Refused` (a write)
or :class:`~telethermo.remote.errors.Failure` with the CiA 301 text of the abort code; a silent node
raises Failure saying it did not answer.
"""

from __future__ import annotations

from typing import Any

import canopen
from canopen.sdo.exceptions import SdoAbortedError, SdoCommunicationError

from telethermo.device.eds_info import EdsInfo, VarInfo
from telethermo.remote.codec import decode, struct_of
from telethermo.remote.errors import Failure, Refused, UserError, abort_text
from telethermo.remote.targets import Target, eds_info, lookup
from telethermo.remote.values import check_range


def remote_node(nw: canopen.Network, node_id: int, timeout_s: float = 1.0) -> canopen.RemoteNode:
    """canopen's SDO client of ``node_id`` on ``nw`` (empty object dictionary), one attempt per request."""
    node = canopen.RemoteNode(node_id, canopen.ObjectDictionary())
    node.sdo.RESPONSE_TIMEOUT = timeout_s
    node.sdo.MAX_RETRIES = 1  # canopen counts attempts: 1 = no retry (0 would retry forever)
    nw.add_node(node)
    return node


class NodeClient:
    """SDO access by EDS name to one node (``target``) on ``nw``."""

    def __init__(self, nw: canopen.Network, target: Target, timeout_s: float = 1.0) -> None:
        self.t = target
        self.node = remote_node(nw, target.node_id, timeout_s)

    @property
    def eds(self) -> EdsInfo:
        return eds_info(self.t)

    def info(self, key: str | int | tuple[int, int]) -> VarInfo:
        """The EDS variable ``key`` (a name, ``0x1018:1``, or (index, sub)); UserError if unknown."""
        return lookup(self.t, key)

    def read(self, info: VarInfo) -> Any:
        """Read one variable by SDO; Failure with the abort text or 'did not answer'."""
        t = self.t
        try:
            data = self.node.sdo.upload(info.index, info.subindex)
        except SdoAbortedError as exc:
            raise Failure(
                f"{t.role} (node {t.node_id}) refused to read {info.key}: {abort_text(exc.code)}"
            ) from None
        except SdoCommunicationError as exc:
            raise Failure(f"{t.role} (node {t.node_id}) did not answer reading {info.key} ({exc})") from None
        return decode(info, data)

    def write(self, info: VarInfo, value: Any) -> None:
        """Write one variable by SDO (expedited, not range-checked); Refused with the abort code and its
        meaning, Failure if the node does not answer."""
        t = self.t
        st = struct_of(info)
        if st is None:
            raise UserError(f"{info.key}: writing a {info.type_name} is not supported")
        try:
            self.node.sdo.download(info.index, info.subindex, st.pack(value))
        except SdoAbortedError as exc:
            raise Refused(
                f"{t.role} (node {t.node_id}) refused {info.key} = {value}: {abort_text(exc.code)}", exc.code
            ) from None
        except SdoCommunicationError as exc:
            raise Failure(f"{t.role} (node {t.node_id}) did not answer writing {info.key} ({exc})") from None

    def get(self, key: str | int | tuple[int, int]) -> Any:
        """The value of the object named ``key``."""
        return self.read(self.info(key))

    def set(self, key: str | int | tuple[int, int], value: Any) -> None:
        """Write the object named ``key``, range-checked against the EDS first (UserError, nothing sent)."""
        info = self.info(key)
        check_range(info, value)
        self.write(info, value)

    def raw_get(self, index: int, sub: int) -> int:
        return int(self.get((index, sub)))

    def raw_set(self, index: int, sub: int, value: int) -> None:
        self.set((index, sub), value)
