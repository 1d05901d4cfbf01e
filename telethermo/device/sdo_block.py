"""Server side of the SDO block transfers of CiA 301 (v4.2 §7.2.4.3.9 .. §7.2.4.3.17).

canopen's ``SdoServer`` serves expedited and segmented transfers only (it aborts a block download
with 0x05040001 and answers a block upload with a normal upload). :class:`BlockServer` adds block
download and block upload. It is pure: request frames (the 8 data bytes on 0x600+id) in, response
frames (for 0x580+id) out; reading and writing the object dictionary are the callables it is given
(the device passes its own SDO paths, so EDS range checks, write validators and write listeners
apply exactly as for a segmented download).

What CiA 301 says, as implemented here:

- **Block download** (client → server): initiate ``ccs=6 | cc | s | cs=0``, index, sub, size (if
  ``s``); the server answers ``scs=5 | sc | ss=0``, index, sub, ``blksize`` (1..127 segments per
  sub-block). The client then sends sub-blocks of segments: byte 0 is ``c << 7 | seqno`` (seqno
  1..blksize, ``c`` on the segment with the last data), 7 data bytes. After the segment with
  seqno = blksize, or the one with ``c``, the server acknowledges ``scs=5 | ss=2``, ``ackseq`` (the
  last segment received in sequence: the client repeats everything after it in the next sub-block,
  renumbered from 1) and the next blksize. Segments out of sequence (one was lost) are ignored. End:
  ``ccs=6 | n << 2 | cs=1`` with ``n`` the bytes of the last segment that carry no data and the
  CRC; the server checks the CRC (if both sides support it; 0x05040004 on a mismatch), stores the
  data and answers ``scs=5 | ss=1``.
- **Block upload** (server → client): initiate ``ccs=5 | cc | cs=0``, index, sub, ``blksize``
  (1..127, else abort 0x05040002), ``pst``; the server answers ``scs=6 | sc | s | ss=0``, index,
  sub, size. The client starts the transfer with ``ccs=5 | cs=3``; the server sends a sub-block of
  at most blksize segments; the client acknowledges ``ccs=5 | cs=2``, ackseq, next blksize, and the
  server continues after the acknowledged segment (repeating the rest). When the segment with
  ``c`` is acknowledged the server ends with ``scs=6 | n << 2 | ss=1`` and the CRC; the client
  confirms with ``ccs=5 | cs=1``.
- **Protocol switch threshold**: if the client's ``pst`` > 0 and the data are no longer than
  ``pst`` bytes, the server *may* switch to the normal (expedited or segmented) upload.
  :meth:`BlockServer.on_request` then returns None and the caller lets its normal SDO server answer
  the same request (canopen's does exactly that for a block upload).
- **CRC**: x^16 + x^12 + x^5 + 1, initial value 0 (CRC-16-CCITT as CiA 301 specifies it; the same
  as CRC-16/XMODEM and as canopen's client), over the data bytes only.
- **Aborts**: a frame that fits no step 0x05040001; an invalid block size 0x05040002; a sequence
  number of 0 or above the block size, or an acknowledge of segments never sent 0x05040003; a CRC
  mismatch 0x05040004; a size other than the one indicated 0x06070010; no data 0x08000024 (as
  canopen's server says for an empty object); :meth:`BlockServer.timeout` 0x05040000. An abort from
  the client (``0x80``) ends the transfer without an answer.
"""

from __future__ import annotations

import binascii
import struct
from typing import Callable

from canopen import SdoAbortedError

from telethermo.cia301 import (
    ABORT_BLOCK_SIZE,
    ABORT_COMMAND_SPECIFIER,
    ABORT_CRC,
    ABORT_LENGTH,
    ABORT_NO_DATA,
    ABORT_SEQNO,
    ABORT_TIMEOUT,
)

MAX_BLKSIZE = 127
SEG = 7  # data bytes per segment

Reader = Callable[[int, int], bytes]
Writer = Callable[[int, int, bytes], None]
Checker = Callable[[int, int, int | None], None]


def crc16(data: bytes | bytearray, crc: int = 0) -> int:
    """CiA 301 block transfer CRC: polynomial x^16+x^12+x^5+1 (0x1021), initial value 0, no
    reflection, no final XOR (check value 0x31C3 for b"123456789")."""
    return binascii.crc_hqx(bytes(data), crc)


def abort_frame(index: int, subindex: int, code: int) -> bytes:
    """SDO abort transfer: ``0x80``, index, sub, abort code (CiA 301 §7.2.4.3.17)."""
    return struct.pack("<BHBL", 0x80, index, subindex, code)


def _frame(*parts: bytes | bytearray) -> bytes:
    return b"".join(parts).ljust(8, b"\x00")


class BlockServer:
    """The block transfers of one SDO server channel (CiA 301 allows one transfer per channel).

    ``read(index, sub) -> bytes`` and ``write(index, sub, data)`` access the object dictionary;
    ``check_download(index, sub, size)`` is called at a block download's initiate with the indicated size
    in bytes (None if not indicated): refuse a read-only or missing object, or a wrong size, before any
    data flow. All three refuse by raising ``SdoAbortedError(code)``;
    the transfer is then aborted with that code. ``blksize``: the sub-block size the server asks
    for in a block download (1..127).
    """

    def __init__(
        self, read: Reader, write: Writer, check_download: Checker | None = None, blksize: int = MAX_BLKSIZE
    ):
        self.read, self.write, self.check_download = read, write, check_download
        self.blksize = blksize
        self.index = self.subindex = 0
        self.reset()

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        """Forget any transfer (no frame: the caller decides whether to abort)."""
        self.direction: str | None = None  # "download", "upload" or None
        self._step = ""  # download: "segments"/"end"; upload: "start"/"sub"/"end"
        self._crc = False  # both sides use the CRC
        self._blk = 0  # size of the current sub-block
        self._seq = 0  # download: last seqno received in sequence in this sub-block
        self._last = False  # download: the segment with c was received in sequence
        self._size: int | None = None  # download: size indicated by the client
        self._buf = bytearray()  # download: data received; upload: data to send
        self._pos = 0  # upload: bytes acknowledged by the client
        self._sent = 0  # upload: segments in the sub-block last sent

    def abort(self, code: int) -> bytes:
        """End the transfer; the abort frame for the object it addressed."""
        self.reset()
        return abort_frame(self.index, self.subindex, code)

    def timeout(self) -> bytes | None:
        """The client let the transfer sit idle: abort 0x05040000 (None if no transfer is open)."""
        return None if self.direction is None else self.abort(ABORT_TIMEOUT)

    # ------------------------------------------------------------------ dispatch
    def on_request(self, data: bytes | bytearray) -> list[bytes] | None:
        """One request frame (8 bytes) → the response frames (possibly none).

        None means "protocol switch": the client's pst allows a normal upload of these data and the
        caller's normal SDO server should answer this very request.
        """
        data = bytes(data)
        if data[0] == 0x80:  # abort transfer from the client: no answer
            self.reset()
            return []
        try:
            if self.direction == "download":  # every frame but an abort belongs to the download
                return self._download_frame(data)
            ccs, cs = data[0] & 0xE0, data[0] & 0x03
            if ccs == 0xC0 and cs & 1 == 0:
                return self._download_initiate(data)
            if ccs == 0xA0 and cs == 0:
                return self._upload_initiate(data)
            if ccs == 0xA0 and self.direction == "upload":
                return self._upload_frame(data, cs)
            return [self.abort(ABORT_COMMAND_SPECIFIER)]
        except SdoAbortedError as exc:
            return [self.abort(exc.code)]

    # ------------------------------------------------------------------ block download
    def _download_initiate(self, data: bytes) -> list[bytes]:
        """Initiate block download: check the object, answer with sc and the block size."""
        if not 1 <= self.blksize <= MAX_BLKSIZE:
            raise ValueError(f"blksize must be in 1..{MAX_BLKSIZE}, got {self.blksize}")
        self.reset()
        self.index, self.subindex = struct.unpack_from("<HB", data, 1)
        size = struct.unpack_from("<L", data, 4)[0] if data[0] & 0x02 else None
        if self.check_download is not None:
            self.check_download(self.index, self.subindex, size)
        self.direction, self._step = "download", "segments"
        self._crc = bool(data[0] & 0x04)
        self._size = size
        self._blk = self.blksize
        sc = 0x04 if self._crc else 0x00
        return [_frame(bytes([0xA0 | sc]), struct.pack("<HBB", self.index, self.subindex, self._blk))]

    def _download_frame(self, data: bytes) -> list[bytes]:
        if self._step == "end":
            if data[0] & 0xE1 != 0xC1:  # ccs 6, cs 1 (end); n in bits 4..2, bit 1 reserved
                return [self.abort(ABORT_COMMAND_SPECIFIER)]
            return self._download_end(data)
        return self._download_segment(data)

    def _download_segment(self, data: bytes) -> list[bytes]:
        """A segment of a sub-block: keep it if it is the next in sequence, ignore it otherwise (one
        was lost); acknowledge at the end of the sub-block with the last seqno received in sequence."""
        seq, c = data[0] & 0x7F, bool(data[0] & 0x80)
        if not 1 <= seq <= self._blk:
            return [self.abort(ABORT_SEQNO)]
        if seq == self._seq + 1 and not self._last:
            self._buf += data[1:8]
            self._seq, self._last = seq, c
        if seq < self._blk and not c:
            return []
        ack = _frame(bytes([0xA2, self._seq, self.blksize]))
        self._seq, self._blk = 0, self.blksize
        if self._last:
            self._step = "end"
        return [ack]

    def _download_end(self, data: bytes) -> list[bytes]:
        """End block download: drop the n unused bytes, check size and CRC, store, confirm."""
        n = (data[0] >> 2) & 0x07
        payload = bytes(self._buf[: len(self._buf) - n])
        if self._size is not None and len(payload) != self._size:
            return [self.abort(ABORT_LENGTH)]
        if self._crc and crc16(payload) != struct.unpack_from("<H", data, 1)[0]:
            return [self.abort(ABORT_CRC)]
        self.write(self.index, self.subindex, payload)
        self.reset()
        return [_frame(b"\xa1")]

    # ------------------------------------------------------------------ block upload
    def _upload_initiate(self, data: bytes) -> list[bytes] | None:
        """Initiate block upload: read the object, answer with sc and the size (or switch, pst)."""
        self.reset()
        self.index, self.subindex = struct.unpack_from("<HB", data, 1)
        blksize, pst = data[4], data[5]
        if not 1 <= blksize <= MAX_BLKSIZE:
            return [self.abort(ABORT_BLOCK_SIZE)]
        payload = bytes(self.read(self.index, self.subindex))
        if not payload:
            return [self.abort(ABORT_NO_DATA)]
        if pst and len(payload) <= pst:
            return None
        self.direction, self._step = "upload", "start"
        self._crc, self._blk, self._buf = bool(data[0] & 0x04), blksize, bytearray(payload)
        sc = 0x04 if self._crc else 0x00
        return [_frame(bytes([0xC2 | sc]), struct.pack("<HBL", self.index, self.subindex, len(payload)))]

    def _upload_frame(self, data: bytes, cs: int) -> list[bytes]:
        if self._step == "start" and cs == 3:
            return self._sub_block()
        if self._step == "sub" and cs == 2:
            return self._upload_ack(data[1], data[2])
        if self._step == "end" and cs == 1:
            self.reset()
            return []
        return [self.abort(ABORT_COMMAND_SPECIFIER)]

    def _sub_block(self) -> list[bytes]:
        """The next sub-block: up to blksize segments from the first unacknowledged byte, numbered
        from 1, ``c`` on the segment holding the last byte."""
        frames = []
        pos = self._pos
        for seq in range(1, self._blk + 1):
            chunk = self._buf[pos : pos + SEG]
            pos += SEG
            last = pos >= len(self._buf)
            frames.append(_frame(bytes([seq | (0x80 if last else 0)]), chunk))
            if last:
                break
        self._sent, self._step = len(frames), "sub"
        return frames

    def _upload_ack(self, ackseq: int, blksize: int) -> list[bytes]:
        """Block acknowledge: advance past ``ackseq`` segments, then the next sub-block or the end."""
        if ackseq > self._sent:
            return [self.abort(ABORT_SEQNO)]
        if not 1 <= blksize <= MAX_BLKSIZE:
            return [self.abort(ABORT_BLOCK_SIZE)]
        self._pos = min(len(self._buf), self._pos + SEG * ackseq)
        self._blk = blksize
        if self._pos < len(self._buf):
            return self._sub_block()
        self._step = "end"
        n = -len(self._buf) % SEG
        crc = crc16(self._buf) if self._crc else 0
        return [_frame(bytes([0xC1 | n << 2]), struct.pack("<H", crc))]
