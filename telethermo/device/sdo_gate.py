"""SDO server gate of a device: canopen's SDO server (expedited and segmented transfers) served only in
PRE-OPERATIONAL and OPERATIONAL, with the transfer state it lacks (a segment request without its
transfer is aborted with 0x05040001), and block upload/download (:mod:`.sdo_block`) through the same
read and write paths as segmented transfers.

What canopen's server leaves out of a segmented transfer, as CANopenNode's CO_SDOserver does it:

- the initiate of a segmented (or block) download is refused at once, before any data flow, for a
  missing object (0x06020000) or sub-index (0x06090011), a read-only object (0x06010002), and an
  indicated size other than the object's (a number or BOOLEAN: larger 0x06070012, smaller 0x06070013;
  a string may be shorter);
- a segmented transfer whose client stays silent ``segment_timeout_s()`` is aborted with 0x05040000
  (a later segment then finds no transfer: 0x05040001)."""

from __future__ import annotations

from typing import Callable

from canopen import SdoAbortedError

import struct

from canopen import objectdictionary as odmod

from telethermo.device import canopen_adapter as adapter
from telethermo.cia301 import (
    ABORT_COMMAND_SPECIFIER,
    ABORT_GENERAL,
    ABORT_LENGTH_HIGH,
    ABORT_LENGTH_LOW,
    ABORT_READ_ONLY,
    ABORT_TIMEOUT,
)
from telethermo.device.context import SERVING, DeviceCore
from telethermo.device.sdo_block import BlockServer, abort_frame


class SdoGate:
    """Frames on 0x600 + node-ID, to canopen's server or to the block server.

    ``block_size()``: sub-block size asked for in a block download (1..127 segments);
    ``block_timeout_s()``: a block transfer whose client stays silent this long is aborted (0x05040000);
    ``segment_timeout_s()``: the same for a segmented transfer.
    """

    def __init__(
        self,
        core: DeviceCore,
        node: adapter.GatedLocalNode,
        *,
        block_size: Callable[[], int],
        block_timeout_s: Callable[[], float],
        segment_timeout_s: Callable[[], float],
    ):
        self.core = core
        self.node = node
        self.block_size = block_size
        self.block_timeout_s = block_timeout_s
        self.segment_timeout_s = segment_timeout_s
        self.transfer: str | None = None  # segmented SDO transfer in progress: "up", "down" or None
        self._where = (0, 0)  # index, sub-index of the segmented transfer
        self._seg_deadline = 0.0
        # block transfers (canopen's server has none): reads and writes through the same paths as its
        # segmented transfers (read callbacks; set_data -> the device's write path with range checks)
        self.block = BlockServer(
            lambda i, s: node.get_data(i, s, check_readable=True),
            lambda i, s, d: node.set_data(i, s, d, check_writable=True),
            self.check_download,
        )
        self._block_deadline = 0.0

    def reset(self) -> None:
        """NMT reset: no transfer is open any more."""
        self.transfer = None
        self.block.reset()
        self.core.scheduler.cancel("sdo-segment")

    def on_frame(self, can_id: int, data: bytes | bytearray, timestamp: float) -> None:
        core = self.core
        if core.extended:
            return  # a 29-bit ID is no service of ours (counted as unknown)
        if len(data) != 8:
            core.stats.malformed_frames += 1
            return
        if core.state not in SERVING:
            return
        sdo = self.node.sdo
        adapter.prime_sdo_abort(sdo)
        if self._block_frame(data):
            return
        # canopen's server keeps no transfer state: a segment request with no segmented transfer in
        # progress makes it raise (TypeError on a None buffer) or re-use an old buffer; CiA 301 wants
        # abort 0x05040001 (client/server command specifier not valid)
        ccs = data[0] & 0xE0
        if ccs in (0x00, 0x60) and self.transfer != ("down" if ccs == 0x00 else "up"):
            self.transfer = None
            sdo.abort(ABORT_COMMAND_SPECIFIER)
            return
        if ccs == 0x20 and not data[0] & 0x02 and self._refuse_download(data):
            return
        before = adapter.sdo_buffer(sdo)
        try:
            sdo.on_request(can_id, data, timestamp)
        except Exception:  # never into the notifier (canopen would drop the rest of the frame's callbacks)
            core.callback_failed(sdo.on_request)
            self.transfer = None
            return
        self._track(ccs, data[0], before, adapter.sdo_buffer(sdo))
        if ccs in (0x20, 0x40, 0xA0):
            self._where = struct.unpack_from("<HB", data, 1)
        if self.transfer is None:
            core.scheduler.cancel("sdo-segment")
        else:
            self._seg_deadline = core.clock() + self.segment_timeout_s()
            core.scheduler.set("sdo-segment", self._seg_deadline, self._segment_timeout)

    def check_download(self, index: int, subindex: int, size: int | None) -> None:
        """At a segmented or block download's initiate: the object exists (0x06020000/0x06090011), is
        writable (0x06010002), and takes ``size`` bytes (if indicated): a number or BOOLEAN has one size
        (0x06070012 longer, 0x06070013 shorter); strings and domains may be shorter."""
        var = self.node.find(index, subindex)
        if not var.writable:
            raise SdoAbortedError(ABORT_READ_ONLY)
        if size is not None and (var.data_type in odmod.NUMBER_TYPES or var.data_type == odmod.BOOLEAN):
            want = max(1, len(var) // 8)
            if size != want:
                raise SdoAbortedError(ABORT_LENGTH_HIGH if size > want else ABORT_LENGTH_LOW)

    def _refuse_download(self, data: bytes | bytearray) -> bool:
        """Initiate segmented download: abort it at once when :meth:`check_download` refuses (True)."""
        index, sub = struct.unpack_from("<HB", data, 1)
        size = struct.unpack_from("<L", data, 4)[0] if data[0] & 0x01 else None
        try:
            self.check_download(index, sub, size)
        except SdoAbortedError as exc:
            self.transfer = None
            self.core.scheduler.cancel("sdo-segment")
            self.core.send(self.node.sdo.tx_cobid, abort_frame(index, sub, exc.code))
            return True
        return False

    def _segment_timeout(self) -> None:
        """Scheduler job: an idle segmented transfer is aborted with 0x05040000 (silently outside
        PRE-OPERATIONAL/OPERATIONAL, where the device sends no SDO)."""
        core = self.core
        with core.lock:
            if self.transfer is None or core.clock() < self._seg_deadline:
                return  # finished, or a frame came meanwhile (it re-armed the job)
            self.transfer = None
            serving = core.running and core.state in SERVING
        if serving:
            core.send(self.node.sdo.tx_cobid, abort_frame(*self._where, ABORT_TIMEOUT))

    def _track(self, ccs: int, command: int, before: bytearray | None, after: bytearray | None) -> None:
        """The segmented transfer open after canopen's server handled one request."""
        if ccs in (0x40, 0xA0):  # initiate upload: segmented if it filled a new buffer
            self.transfer = "up" if after is not before and after else None
        elif ccs == 0x20:  # initiate download: segmented unless expedited (and not aborted)
            self.transfer = "down" if not command & 0x02 and after is not before else None
        elif ccs == 0x60 and not after:
            self.transfer = None  # the last segment went out
        elif ccs == 0x00 and command & 0x01:
            self.transfer = None  # the last segment came in
        elif ccs == 0x80:
            self.transfer = None  # the client aborted

    def _block_frame(self, data: bytes | bytearray) -> bool:
        """Serve a block transfer frame (CiA 301 §7.2.4.3.9 ff., :mod:`.sdo_block`); False if canopen's
        server is to serve the frame.

        Block frames: an initiate block upload/download (ccs 5/6), the client's start/acknowledge/end
        (ccs 5) of an open block upload, and every frame but an abort (0x80) during a block download
        (its segments carry ``c | seqno`` in byte 0, no command specifier). Any other frame ends an
        open block transfer (one transfer per channel) and goes to canopen's server as before. A
        protocol switch (the client's pst allows a normal upload) also goes to canopen's server, whose
        block upload is a normal upload.
        """
        core, block = self.core, self.block
        ccs = data[0] & 0xE0
        if not (ccs in (0xA0, 0xC0) or (block.direction == "download" and data[0] != 0x80)):
            if block.direction is not None:
                with core.lock:
                    block.reset()
            return False
        self.transfer = None  # a block initiate ends a segmented transfer too
        with core.lock:
            block.blksize = self.block_size()
            try:
                frames = block.on_request(data)
            except Exception:  # never into the notifier: count it, abort the transfer
                core.callback_failed(block.on_request)
                frames = [block.abort(ABORT_GENERAL)]
            if block.direction is not None:
                self._block_deadline = core.clock() + self.block_timeout_s()
                core.scheduler.set("sdo-block", self._block_deadline, self._block_timeout)
        if frames is None:
            return False
        for frame in frames:
            core.send(self.node.sdo.tx_cobid, frame)
        return True

    def _block_timeout(self) -> None:
        """Scheduler job: an idle block transfer is aborted with 0x05040000 (silently outside
        PRE-OPERATIONAL/OPERATIONAL, where the device sends no SDO)."""
        core = self.core
        with core.lock:
            if self.block.direction is None or core.clock() < self._block_deadline:
                return  # finished, or a frame came meanwhile (it re-armed the job)
            frame = self.block.timeout()
            serving = core.running and core.state in SERVING
        if serving and frame is not None:
            core.send(self.node.sdo.tx_cobid, frame)
