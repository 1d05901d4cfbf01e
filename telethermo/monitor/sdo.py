"""One SDO state machine per SDO channel (client request COB-ID, server response COB-ID).

CiA 301 allows one transfer at a time per channel, so following the request/response pairs of one
node's default channel (0x600+id / 0x580+id) is exact, whatever other nodes do meanwhile: the
monitor keeps one :class:`SdoChannel` per node (not one parser for the whole bus).

Covered: expedited and segmented upload and download, block download and block upload (with
sub-block retransmission after a partial acknowledge, CRC not checked), a server switching a block
upload to a normal upload (allowed by CiA 301, done by canopen's SdoServer), aborts from either side
with the CiA 301 text (also in the middle of a sub-block: seqno 0 does not exist, so a frame starting
with 0x80 there is an abort, not a segment), and protocol faults (toggle bit not alternated, a frame
that fits no open transfer) reported as problems instead of being silently dropped.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from typing import Any

from telethermo.cia301 import sdo_abort_text

IDLE = "idle"
DL_INIT, DL_SEG_REQ, DL_SEG_RESP = "dl_init", "dl_seg_req", "dl_seg_resp"
UL_INIT, UL_SEG_REQ, UL_SEG_RESP = "ul_init", "ul_seg_req", "ul_seg_resp"
BDL_INIT, BDL_SUB, BDL_ACK, BDL_END_REQ, BDL_END_RESP = (
    "bdl_init",
    "bdl_sub",
    "bdl_ack",
    "bdl_end_req",
    "bdl_end_resp",
)
BUL_INIT, BUL_START, BUL_SUB, BUL_END, BUL_END_RESP = (
    "bul_init",
    "bul_start",
    "bul_sub",
    "bul_end",
    "bul_end_resp",
)


@dataclass(slots=True)
class SdoTransfer:
    """One SDO transfer, complete or aborted.

    Attributes:
        node: the server's node-ID.
        direction: "download" (client writes the server's OD) or "upload" (client reads).
        index, subindex: the object addressed.
        mode: "expedited", "segmented" or "block".
        data: the bytes transferred (as far as they got).
        size: the size the initiating frame declared, bytes (None if not indicated).
        status: "ok", "aborted" or "error" (protocol fault; see ``problem``).
        abort_code, abort_text: the abort and its CiA 301 meaning (status "aborted").
        aborted_by: "server" or "client".
        t_start_s, t_end_s: times of the first and last frame, s.
        problem: what went wrong for status "error".
    """

    node: int
    direction: str
    index: int
    subindex: int
    mode: str = "expedited"
    data: bytes = b""
    size: int | None = None
    status: str = "in progress"
    abort_code: int | None = None
    abort_text: str | None = None
    aborted_by: str | None = None
    t_start_s: float = 0.0
    t_end_s: float = 0.0
    problem: str | None = None

    def to_json(self) -> dict[str, Any]:
        return {
            "node": self.node,
            "direction": self.direction,
            "index": self.index,
            "subindex": self.subindex,
            "mode": self.mode,
            "data": self.data.hex(),
            "size": self.size,
            "status": self.status,
            "abort_code": self.abort_code,
            "abort_text": self.abort_text,
            "aborted_by": self.aborted_by,
            "t_start_s": self.t_start_s,
            "t_end_s": self.t_end_s,
            "problem": self.problem,
        }


@dataclass(slots=True)
class SdoStep:
    """What one frame did: a one-line description, a finished transfer and/or a protocol problem."""

    text: str
    done: SdoTransfer | None = None
    problem: str | None = None


@dataclass
class SdoChannel:
    """State machine of one SDO channel (one server node)."""

    node: int
    state: str = IDLE
    cur: SdoTransfer | None = None
    toggle: int = 0
    last_seg: bool = False
    last_seq: int | None = None
    blksize: int = 0
    seq_data: dict[int, bytes] = field(default_factory=dict)
    tail_n: int = 0

    # -- helpers ---------------------------------------------------------------------------------
    def _start(self, t: float, direction: str, index: int, sub: int, mode: str) -> SdoTransfer | None:
        stale = None
        if self.cur is not None:
            stale = self._finish(
                t,
                "error",
                problem=f"{self.cur.direction} of 0x{self.cur.index:04X}:"
                f"{self.cur.subindex:02X} interrupted by a new transfer",
            )
        self.cur = SdoTransfer(self.node, direction, index, sub, mode, t_start_s=t, t_end_s=t)
        self.toggle, self.last_seg, self.seq_data, self.last_seq = 0, False, {}, None
        return stale

    def _finish(self, t: float, status: str, *, problem: str | None = None) -> SdoTransfer:
        tr = self.cur
        assert tr is not None
        tr.status, tr.t_end_s, tr.problem = status, t, problem
        self.cur, self.state = None, IDLE
        return tr

    def _unexpected(self, t: float, what: str) -> SdoStep:
        msg = f"unexpected {what} in state {self.state}"
        if self.cur is not None:
            done = self._finish(t, "error", problem=msg)
            return SdoStep(f"{what} (protocol error)", done, msg)
        self.state = IDLE
        return SdoStep(f"{what} (no transfer open)", None, msg)

    def _abort(self, t: float, data: bytes, by: str) -> SdoStep:
        if len(data) < 8:
            return self._unexpected(t, "short abort frame")
        _, index, sub, code = struct.unpack_from("<BHBL", data)
        text = f"abort 0x{index:04X}:{sub:02X} 0x{code:08X} {sdo_abort_text(code)} (by {by})"
        if self.cur is None:
            self.cur = SdoTransfer(self.node, "unknown", index, sub, t_start_s=t)
        tr = self.cur
        tr.abort_code, tr.abort_text, tr.aborted_by = code, sdo_abort_text(code), by
        return SdoStep(text, self._finish(t, "aborted"))

    def _check_toggle(self, t: float, cmd: int, what: str) -> SdoStep | None:
        tog = (cmd >> 4) & 1
        if tog != self.toggle:
            msg = f"toggle bit not alternated in {what} (got {tog}, expected {self.toggle})"
            done = self._finish(t, "error", problem=msg) if self.cur else None
            return SdoStep(f"{what} (toggle error)", done, msg)
        return None

    # -- client -> server ------------------------------------------------------------------------
    def request(self, t: float, data: bytes) -> SdoStep:
        """Feed a frame from the client (COB-ID 0x600 + node)."""
        data = bytes(data)
        if not data:
            return self._unexpected(t, "empty SDO request")
        cmd = data[0]
        if self.state == BDL_SUB and cmd != 0x80:  # block download segments carry no command specifier;
            return self._bdl_segment(t, data)  # 0x80 (c=1, seqno 0: no such segment) is an abort
        ccs = cmd >> 5
        if self.cur is not None:
            self.cur.t_end_s = t
        if ccs == 4:
            return self._abort(t, data, "client")
        handler = {
            0: self._download_segment,
            1: self._initiate_download,
            2: self._initiate_upload,
            3: self._upload_segment_request,
            5: self._block_upload_request,
            6: self._block_download_request,
        }.get(ccs)
        if handler is None:
            return self._unexpected(t, f"client command specifier {ccs}")
        return handler(t, data, cmd)

    def _initiate_download(self, t: float, data: bytes, cmd: int) -> SdoStep:
        if len(data) < 8:
            return self._unexpected(t, "short initiate download")
        index, sub = struct.unpack_from("<HB", data, 1)
        e, s, n = (cmd >> 1) & 1, cmd & 1, (cmd >> 2) & 3
        stale = self._start(t, "download", index, sub, "expedited" if e else "segmented")
        if e:
            self.cur.data = data[4 : 8 - n] if s else data[4:8]
            self.cur.size = len(self.cur.data) if s else None
        else:
            self.cur.size = struct.unpack_from("<L", data, 4)[0] if s else None
        self.state = DL_INIT
        return self._with_stale(
            SdoStep(f"initiate download 0x{index:04X}:{sub:02X} {self.cur.mode} {self._size_text()}"), stale
        )

    def _download_segment(self, t: float, data: bytes, cmd: int) -> SdoStep:
        if self.state != DL_SEG_REQ:
            return self._unexpected(t, "download segment")
        bad = self._check_toggle(t, cmd, "download segment")
        if bad:
            return bad
        n, c = (cmd >> 1) & 7, cmd & 1
        self.cur.data += data[1 : 8 - n]
        self.last_seg = bool(c)
        self.state = DL_SEG_RESP
        return SdoStep(f"download segment t={self.toggle} {7 - n} bytes{' last' if c else ''}")

    def _initiate_upload(self, t: float, data: bytes, cmd: int) -> SdoStep:
        if len(data) < 4:
            return self._unexpected(t, "short initiate upload")
        index, sub = struct.unpack_from("<HB", data, 1)
        stale = self._start(t, "upload", index, sub, "expedited")
        self.state = UL_INIT
        return self._with_stale(SdoStep(f"initiate upload 0x{index:04X}:{sub:02X}"), stale)

    def _upload_segment_request(self, t: float, data: bytes, cmd: int) -> SdoStep:
        if self.state != UL_SEG_REQ:
            return self._unexpected(t, "upload segment request")
        bad = self._check_toggle(t, cmd, "upload segment request")
        if bad:
            return bad
        self.state = UL_SEG_RESP
        return SdoStep(f"upload segment request t={self.toggle}")

    def _block_download_request(self, t: float, data: bytes, cmd: int) -> SdoStep:
        if cmd & 1 == 0:  # initiate
            if len(data) < 8:
                return self._unexpected(t, "short initiate block download")
            index, sub = struct.unpack_from("<HB", data, 1)
            stale = self._start(t, "download", index, sub, "block")
            self.cur.size = struct.unpack_from("<L", data, 4)[0] if cmd & 2 else None
            self.state = BDL_INIT
            return self._with_stale(
                SdoStep(f"initiate block download 0x{index:04X}:{sub:02X} {self._size_text()}"), stale
            )
        if self.state != BDL_END_REQ:
            return self._unexpected(t, "end block download")
        n = (cmd >> 2) & 7
        if n:
            self.cur.data = self.cur.data[:-n]
        self.state = BDL_END_RESP
        return SdoStep(f"end block download ({n} bytes unused in last segment)")

    def _block_upload_request(self, t: float, data: bytes, cmd: int) -> SdoStep:
        cs = cmd & 3
        if cs == 0:
            if len(data) < 6:
                return self._unexpected(t, "short initiate block upload")
            index, sub = struct.unpack_from("<HB", data, 1)
            stale = self._start(t, "upload", index, sub, "block")
            self.blksize = data[4]
            self.state = BUL_INIT
            return self._with_stale(
                SdoStep(f"initiate block upload 0x{index:04X}:{sub:02X} blksize {self.blksize}"), stale
            )
        if cs == 3:
            if self.state != BUL_START:
                return self._unexpected(t, "start block upload")
            self.state, self.seq_data, self.last_seq = BUL_SUB, {}, None
            return SdoStep("start block upload")
        if cs == 2:
            if self.state != BUL_SUB:
                return self._unexpected(t, "block upload acknowledge")
            ackseq, self.blksize = data[1], data[2]
            self.state = BUL_END if self._ack(ackseq) else BUL_SUB
            return SdoStep(f"block upload ack seq {ackseq}, next blksize {self.blksize}")
        if cs == 1:
            if self.state != BUL_END_RESP:
                return self._unexpected(t, "end block upload response")
            return SdoStep("end block upload response", self._finish(t, "ok"))

    # -- server -> client ------------------------------------------------------------------------
    def response(self, t: float, data: bytes) -> SdoStep:
        """Feed a frame from the server (COB-ID 0x580 + node)."""
        data = bytes(data)
        if not data:
            return self._unexpected(t, "empty SDO response")
        cmd = data[0]
        if self.state == BUL_SUB and cmd != 0x80:  # block upload segments carry no command specifier;
            return self._bul_segment(t, data)  # 0x80 (c=1, seqno 0: no such segment) is an abort
        scs = cmd >> 5
        if self.cur is not None:
            self.cur.t_end_s = t
        if scs == 4:
            return self._abort(t, data, "server")
        handler = {
            0: self._upload_segment_response,
            1: self._download_segment_response,
            2: self._initiate_upload_response,
            3: self._initiate_download_response,
            5: self._block_download_response,
            6: self._block_upload_response,
        }.get(scs)
        if handler is None:
            return self._unexpected(t, f"server command specifier {scs}")
        return handler(t, data, cmd)

    def _initiate_download_response(self, t: float, data: bytes, cmd: int) -> SdoStep:
        if self.state != DL_INIT:
            return self._unexpected(t, "initiate download response")
        if self.cur.mode == "expedited":
            return SdoStep("download confirmed", self._finish(t, "ok"))
        self.state, self.toggle = DL_SEG_REQ, 0
        return SdoStep("initiate download confirmed")

    def _download_segment_response(self, t: float, data: bytes, cmd: int) -> SdoStep:
        if self.state != DL_SEG_RESP:
            return self._unexpected(t, "download segment response")
        bad = self._check_toggle(t, cmd, "download segment response")
        if bad:
            return bad
        if self.last_seg:
            return SdoStep(f"download segment confirmed t={self.toggle}, done", self._finish(t, "ok"))
        self.toggle ^= 1
        self.state = DL_SEG_REQ
        return SdoStep(f"download segment confirmed t={self.toggle ^ 1}")

    def _initiate_upload_response(self, t: float, data: bytes, cmd: int) -> SdoStep:
        if self.state not in (UL_INIT, BUL_INIT):
            return self._unexpected(t, "initiate upload response")
        e, s, n = (cmd >> 1) & 1, cmd & 1, (cmd >> 2) & 3
        if self.state == BUL_INIT:
            self.cur.mode = "expedited"
        if e:
            self.cur.data = data[4 : 8 - n] if s else data[4:8]
            self.cur.size = len(self.cur.data) if s else None
            return SdoStep(f"upload response expedited {len(self.cur.data)} bytes", self._finish(t, "ok"))
        self.cur.mode = "segmented"
        self.cur.size = struct.unpack_from("<L", data, 4)[0] if s and len(data) >= 8 else None
        self.state, self.toggle = UL_SEG_REQ, 0
        return SdoStep(f"upload response segmented {self._size_text()}")

    def _upload_segment_response(self, t: float, data: bytes, cmd: int) -> SdoStep:
        if self.state != UL_SEG_RESP:
            return self._unexpected(t, "upload segment response")
        bad = self._check_toggle(t, cmd, "upload segment response")
        if bad:
            return bad
        n, c = (cmd >> 1) & 7, cmd & 1
        self.cur.data += data[1 : 8 - n]
        if c:
            return SdoStep(f"upload segment t={self.toggle} {7 - n} bytes last", self._finish(t, "ok"))
        self.toggle ^= 1
        self.state = UL_SEG_REQ
        return SdoStep(f"upload segment t={self.toggle ^ 1} {7 - n} bytes")

    def _block_download_response(self, t: float, data: bytes, cmd: int) -> SdoStep:
        ss = cmd & 3
        if ss == 0:
            if self.state != BDL_INIT:
                return self._unexpected(t, "initiate block download response")
            self.blksize = data[4]
            self.state, self.seq_data, self.last_seq = BDL_SUB, {}, None
            return SdoStep(f"initiate block download confirmed, blksize {self.blksize}")
        if ss == 2:
            if self.state != BDL_ACK:
                return self._unexpected(t, "block download acknowledge")
            ackseq, self.blksize = data[1], data[2]
            self.state = BDL_END_REQ if self._ack(ackseq) else BDL_SUB
            return SdoStep(f"block download ack seq {ackseq}, next blksize {self.blksize}")
        if ss == 1:
            if self.state != BDL_END_RESP:
                return self._unexpected(t, "end block download response")
            return SdoStep("end block download confirmed", self._finish(t, "ok"))
        return self._unexpected(t, f"server command specifier {cmd >> 5}")

    def _block_upload_response(self, t: float, data: bytes, cmd: int) -> SdoStep:
        if cmd & 1 == 0:
            if self.state != BUL_INIT:
                return self._unexpected(t, "initiate block upload response")
            self.cur.size = struct.unpack_from("<L", data, 4)[0] if cmd & 2 and len(data) >= 8 else None
            self.state = BUL_START
            return SdoStep(f"initiate block upload response {self._size_text()}")
        if self.state != BUL_END:
            return self._unexpected(t, "end block upload")
        n = (cmd >> 2) & 7
        if n:
            self.cur.data = self.cur.data[:-n]
        self.state = BUL_END_RESP
        return SdoStep(f"end block upload ({n} bytes unused in last segment)")

    # -- block transfer internals ----------------------------------------------------------------
    def _bdl_segment(self, t: float, data: bytes) -> SdoStep:
        seq, c = data[0] & 0x7F, data[0] >> 7
        self.cur.t_end_s = t
        self.seq_data[seq] = data[1:8]
        if c:
            self.last_seq = seq
        if c or seq >= self.blksize:
            self.state = BDL_ACK
        return SdoStep(f"block download segment {seq}{' last' if c else ''}")

    def _bul_segment(self, t: float, data: bytes) -> SdoStep:
        seq, c = data[0] & 0x7F, data[0] >> 7
        self.cur.t_end_s = t
        self.seq_data[seq] = data[1:8]
        if c:
            self.last_seq = seq
        return SdoStep(f"block upload segment {seq}{' last' if c else ''}")

    def _ack(self, ackseq: int) -> bool:
        """Keep the segments up to the acknowledged one (the sender repeats the rest), append them to
        the data; True if the last segment is now acknowledged."""
        for seq in sorted(self.seq_data):
            if seq <= ackseq:
                self.cur.data += self.seq_data[seq]
        self.seq_data = {}
        done = self.last_seq is not None and self.last_seq <= ackseq
        if not done:
            self.last_seq = None
        return done

    def _size_text(self) -> str:
        return f"{self.cur.size} bytes" if self.cur and self.cur.size is not None else "size not indicated"

    @staticmethod
    def _with_stale(step: SdoStep, stale: SdoTransfer | None) -> SdoStep:
        if stale is not None:
            step.problem = stale.problem
            step.done = stale
        return step
