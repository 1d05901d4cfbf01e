"""CiA 301 conformance checks of the live node pair through an independent client (tests/conformance/lab.py:
canopen's RemoteNode/SdoClient/NmtMaster from the shipped EDS files and raw frames, no project client code).

Each check is (name, clause, fn(lab) -> detail); it raises :class:`CheckFailed` on a deviation. Every check
that disturbs the pair (NMT, peer loss) ends by proving the pair recovered: both nodes OPERATIONAL by their
heartbeats, both TPDO1 flowing, no error left in 0x1001 and no trip in 0x2706 of either node.

The whole suite, in its order, is ``tests.conformance.corners.SUITE``: these checks, the transmission-type and
EMCY checks and the protocol corners of issue 25 (tests/conformance/corners.py).
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from typing import Callable

from canopen import SdoAbortedError, SdoCommunicationError

from telethermo.cia301 import (
    ABORT_NO_OBJECT,
    ABORT_NO_SUBINDEX,
    ABORT_RANGE,
    ABORT_READ_ONLY,
    ABORT_TOO_HIGH,
    ABORT_TOO_LOW,
)

from tests.conformance.lab import MASTER, ROLE, SLAVE, Lab, eds_limits, wait_for

STOPPED, OPERATIONAL, PRE_OPERATIONAL = 4, 5, 127
START, STOP, ENTER_PREOP, RESET_NODE, RESET_COMM = 0x01, 0x02, 0x80, 0x81, 0x82
PEER_LOST_BIT = 0x200  # 0x2706 active_trips: bit 9 (docs/nodes.md)


class CheckFailed(AssertionError):
    """The node did not behave as the clause says."""


def expect(cond: bool, message: str) -> None:
    if not cond:
        raise CheckFailed(message)


@dataclass(frozen=True)
class Check:
    name: str
    clause: str
    fn: Callable[[Lab], str]


def _abort(fn) -> int | None:
    try:
        fn()
    except SdoAbortedError as exc:
        return exc.code
    return None


def _other(node_id: int) -> int:
    return SLAVE if node_id == MASTER else MASTER


# ------------------------------------------------------------------ recovery (post-condition)
def recovered(lab: Lab, timeout_s: float = 30.0) -> str:
    """Both nodes OPERATIONAL, both TPDO1 flowing again, no error and no trip left, both processes alive."""
    mark = lab.frames.mark()
    for nid in (MASTER, SLAVE):
        expect(
            lab.wait_heartbeat(nid, OPERATIONAL, since=mark, timeout_s=timeout_s),
            f"node {nid} not OPERATIONAL again (heartbeats {lab.heartbeat_states(nid, mark)[-3:]})",
        )
        expect(
            lab.wait_frames(0x180 + nid, 20, since=mark, timeout_s=timeout_s),
            f"node {nid}'s TPDO1 does not flow again",
        )
    for nid in (MASTER, SLAVE):
        sdo = lab.sdo(nid)
        expect(
            wait_for(lambda: sdo[0x1001].raw == 0 and sdo["active_trips"].raw == 0, timeout_s, 0.1),
            f"node {nid}: 0x1001 = 0x{sdo[0x1001].raw:02X}, active_trips = 0x{sdo['active_trips'].raw:03X} "
            "after recovery",
        )
    expect(lab.processes_alive(), "a node process ended")
    return "recovered"


# ------------------------------------------------------------------ SDO
def sdo_expedited(lab: Lab) -> str:
    for nid in (MASTER, SLAVE):
        node = lab.nodes[nid]
        expect(node.sdo[0x1000].raw == node.object_dictionary[0x1000].default, f"node {nid}: 0x1000")
        expect(
            node.sdo[0x1018][1].raw == node.object_dictionary[0x1018][1].default, f"node {nid}: 0x1018 sub 1"
        )
        hb = node.sdo[0x1017].raw
        node.sdo.download(0x1017, 0, struct.pack("<H", hb))  # 2 bytes: expedited
        expect(node.sdo[0x1017].raw == hb, f"node {nid}: 0x1017 after an expedited download")
    return "0x1000, 0x1018:1 read, 0x1017 written back"


def sdo_segmented(lab: Lab) -> str:
    for nid in (MASTER, SLAVE):
        node = lab.nodes[nid]
        name = node.sdo.upload(0x1008, 0).decode("ascii")
        expect(name == node.object_dictionary[0x1008].default, f"node {nid}: 0x1008 = {name!r}")
        kp = node.sdo.upload(0x2200, 0)
        node.sdo.download(0x2200, 0, kp, force_segment=True)
        expect(node.sdo.upload(0x2200, 0) == kp, f"node {nid}: 0x2200 after a segmented download")
    return "0x1008 uploaded, 0x2200 downloaded segmented"


def sdo_block(lab: Lab) -> str:
    for nid in (MASTER, SLAVE):
        node = lab.nodes[nid]
        with node.sdo[0x1008].open("rb", block_transfer=True) as f:
            name = f.read().decode("ascii")
        expect(
            name == node.object_dictionary[0x1008].default, f"node {nid}: block upload of 0x1008 = {name!r}"
        )
        kp = node.sdo.upload(0x2200, 0)
        with node.sdo[0x2200].open("wb", size=len(kp), block_transfer=True) as f:
            f.write(kp)
        expect(node.sdo.upload(0x2200, 0) == kp, f"node {nid}: 0x2200 after a block download")
    return "block upload of 0x1008, block download of 0x2200"


def sdo_abort_missing_object(lab: Lab) -> str:
    for nid in (MASTER, SLAVE):
        code = _abort(lambda: lab.nodes[nid].sdo.upload(0x5FFF, 0))
        expect(code == ABORT_NO_OBJECT, f"node {nid}: upload of 0x5FFF aborted with {code and hex(code)}")
    return "0x06020000"


def sdo_abort_missing_subindex(lab: Lab) -> str:
    for nid in (MASTER, SLAVE):
        code = _abort(lambda: lab.nodes[nid].sdo.upload(0x1018, 9))
        expect(
            code == ABORT_NO_SUBINDEX, f"node {nid}: upload of 0x1018 sub 9 aborted with {code and hex(code)}"
        )
    return "0x06090011"


def sdo_abort_read_only(lab: Lab) -> str:
    for nid in (MASTER, SLAVE):
        node = lab.nodes[nid]
        before = node.sdo.upload(0x1000, 0)
        code = _abort(lambda: node.sdo.download(0x1000, 0, b"\x01\x00\x00\x00"))
        expect(code == ABORT_READ_ONLY, f"node {nid}: download to 0x1000 aborted with {code and hex(code)}")
        expect(node.sdo.upload(0x1000, 0) == before, f"node {nid}: 0x1000 changed")
    return "0x06010002"


def sdo_abort_out_of_range(lab: Lab) -> str:
    for nid in (MASTER, SLAVE):
        node = lab.nodes[nid]
        low, high = eds_limits(ROLE[nid], 0x2200)
        kp = node.sdo.upload(0x2200, 0)
        cases = [
            (struct.pack("<f", high + 1.0), ABORT_TOO_HIGH, "above HighLimit"),
            (struct.pack("<f", low - 1.0), ABORT_TOO_LOW, "below LowLimit"),
            (struct.pack("<f", math.nan), ABORT_RANGE, "NaN"),
        ]
        for data, want, what in cases:
            code = _abort(lambda: node.sdo.download(0x2200, 0, data))
            expect(code == want, f"node {nid}: 0x2200 {what}: abort {code and hex(code)}, want 0x{want:08X}")
            expect(node.sdo.upload(0x2200, 0) == kp, f"node {nid}: 0x2200 changed by a refused write")
        flag = node.sdo.upload(0x230C, 0)
        code = _abort(lambda: node.sdo.download(0x230C, 0, b"\x02"))
        expect(code == ABORT_RANGE, f"node {nid}: BOOLEAN 0x230C = 2: abort {code and hex(code)}")
        expect(node.sdo.upload(0x230C, 0) == flag, f"node {nid}: 0x230C changed by a refused write")
    return "0x06090031 / 0x06090032 / 0x06090030 (NaN, BOOLEAN 2), values unchanged"


# ------------------------------------------------------------------ SYNC
def sync_counter(lab: Lab) -> str:
    master, slave = lab.sdo(MASTER), lab.sdo(SLAVE)
    cob = master[0x1005].raw
    expect(
        cob & (1 << 30) and not slave[0x1005].raw & (1 << 30),
        "exactly the master produces SYNC (0x1005 bit 30)",
    )
    overflow = master[0x1019].raw
    counted = slave["sync_count"].raw
    mark = lab.frames.mark()
    expect(lab.wait_frames(cob & 0x7FF, 60, since=mark), "fewer than 60 SYNCs")
    syncs = [d for c, d in lab.frames.since(mark) if c == cob & 0x7FF]
    if overflow == 0:
        expect(all(len(d) == 0 for d in syncs), "SYNC with a counter byte although 0x1019 = 0")
        return "no counter (0x1019 = 0)"
    expect(all(len(d) == 1 for d in syncs), "SYNC without its counter byte (0x1019 > 0)")
    values = [d[0] for d in syncs]
    expect(all(1 <= v <= overflow for v in values), f"counter outside 1..{overflow}")
    steps = {(b - a) % overflow for a, b in zip(values, values[1:])}
    expect(steps == {1}, f"counter steps {sorted(steps)} (not 1 .. 0x1019, then 1)")
    expect(slave["sync_count"].raw >= counted + 60, "the slave did not count the SYNCs (0x2713)")
    return f"{len(values)} SYNCs, counter 1..{overflow} consecutive"


def _sync_counters_before(lab: Lab, mark: int, cob: int) -> list[int]:
    """For each frame ``cob`` since ``mark``: the counter of the SYNC just before it (-1: none yet)."""
    last, out = -1, []
    for c, d in lab.frames.since(mark):
        if c == 0x80 and len(d) == 1:
            last = d[0]
        elif c == cob:
            out.append(last)
    return out


def _remap(sdo, comm: int, mapping: int, entries: list[int], *, start: int | None = None) -> None:
    """CiA 301 7.5.2.36: PDO invalid, sub 0 = 0, the entries, sub 0 = their count, (SYNC start,) PDO valid."""
    cob = sdo[comm][1].raw
    sdo[comm][1].raw = cob | 0x80000000
    sdo[mapping][0].raw = 0
    for i, e in enumerate(entries, 1):
        sdo[mapping][i].raw = e
    sdo[mapping][0].raw = len(entries)
    if start is not None:
        sdo[comm][6].raw = start
    sdo[comm][1].raw = cob & ~0x80000000


def pdo_mapping_procedure(lab: Lab) -> str:
    """The slave's TPDO2 (status, type 10): mapping and SYNC start value refused while valid; the procedure
    remaps it (cycle_counter alone, 4 bytes) and back."""
    sdo = lab.sdo(SLAVE)
    saved = [sdo[0x1A01][i].raw for i in range(1, sdo[0x1A01][0].raw + 1)]
    for sub, index, code in ((0, 0x1A01, 0x06010000), (1, 0x1A01, 0x06010000), (6, 0x1801, ABORT_RANGE)):
        got = _abort(
            lambda: setattr(sdo[index][sub], "raw", 0 if sub == 0 else (0x27020020 if sub == 1 else 3))
        )
        expect(
            got == code, f"0x{index:04X} sub {sub} written while the PDO is valid: abort {got} (0x{code:08X})"
        )
    _remap(sdo, 0x1801, 0x1A01, [0x27020020])
    mark = lab.frames.mark()
    expect(lab.wait_frames(0x282, 3, since=mark), "TPDO2 does not come after the remap")
    frames = [d for c, d in lab.frames.since(mark) if c == 0x282]
    counts = [int.from_bytes(d, "little") for d in frames]
    expect(
        all(len(d) == 4 for d in frames) and counts == sorted(counts), f"TPDO2 after the remap: {frames[:3]}"
    )
    _remap(sdo, 0x1801, 0x1A01, saved)
    mark = lab.frames.mark()
    expect(lab.wait_frames(0x282, 2, since=mark), "TPDO2 does not come after the mapping was put back")
    expect(
        all(len(d) == 4 * len(saved) for c, d in lab.frames.since(mark) if c == 0x282),
        "length after the restore",
    )
    return "refused while valid (0x06010000, 0x06090030); remapped to 4 bytes and back"


def sync_start_value(lab: Lab) -> str:
    """SYNC start value 7 on the slave's TPDO2: after NMT start its first TPDO2 follows the SYNC counter 7."""
    sdo = lab.sdo(SLAVE)
    _remap(sdo, 0x1801, 0x1A01, [sdo[0x1A01][i].raw for i in range(1, sdo[0x1A01][0].raw + 1)], start=7)
    lab.nmt(ENTER_PREOP, SLAVE)
    mark = lab.frames.mark()
    expect(lab.wait_heartbeat(SLAVE, PRE_OPERATIONAL, since=mark), "the slave did not enter PRE-OPERATIONAL")
    lab.nmt(START, SLAVE)
    mark = lab.frames.mark()
    expect(lab.wait_frames(0x282, 3, since=mark, timeout_s=30), "TPDO2 does not come after NMT start")
    before = _sync_counters_before(lab, mark, 0x282)
    _remap(sdo, 0x1801, 0x1A01, [sdo[0x1A01][i].raw for i in range(1, sdo[0x1A01][0].raw + 1)], start=0)
    expect(
        before[0] == 7 and {(b - a) % 240 for a, b in zip(before, before[1:])} == {10},
        f"TPDO2 after the SYNCs with counters {before[:4]} (expected 7, 17, 27, ...)",
    )
    return f"first TPDO2 after SYNC counter {before[0]}; {recovered(lab)}"


def sync_length(lab: Lab) -> str:
    """A SYNC of the wrong length (0x1019 > 0: DLC 1): not processed, EMCY 0x8240 with the length, then
    reset."""
    mark = lab.frames.mark()
    for data in (b"", b"\x01\x02"):
        lab.net.send_message(0x80, data)
    expect(
        wait_for(lambda: lab.emcy_codes(SLAVE, mark).count(0x8240) >= 2, 10),
        f"no EMCY 0x8240 from the slave (EMCYs {[hex(c) for c in lab.emcy_codes(SLAVE, mark)]})",
    )
    lengths = [d[3] for c, d in lab.frames.since(mark) if c == 0x82 and len(d) == 8 and d[:2] == b"\x40\x82"]
    expect(lengths == [0, 2], f"EMCY 0x8240 data: lengths {lengths}")
    return f"EMCY 0x8240 for DLC {lengths}; {recovered(lab)}"


# ------------------------------------------------------------------ heartbeat
def _hb_ratio(lab: Lab, nid: int, other_beats: int = 10) -> float:
    """Heartbeats of ``nid`` per heartbeat of the other node (its 0x1017 unchanged), over ``other_beats`` of
    the other's: the period compared with another producer's on the same machine, not with a wall clock."""
    other = _other(nid)
    mark = lab.frames.mark()
    expect(
        lab.wait_frames(0x700 + other, other_beats + 1, since=mark, timeout_s=30),
        f"node {other} stopped beating",
    )
    frames = lab.frames.since(mark)
    first = next(i for i, (c, _) in enumerate(frames) if c == 0x700 + other)
    last = [i for i, (c, _) in enumerate(frames) if c == 0x700 + other][other_beats]
    return sum(1 for c, _ in frames[first:last] if c == 0x700 + nid) / other_beats


def heartbeat_producer(lab: Lab) -> str:
    details = []
    for nid in (MASTER, SLAVE):
        sdo = lab.sdo(nid)
        base = sdo[0x1017].raw
        try:
            sdo[0x1017].raw = base // 2
            r_half = _hb_ratio(lab, nid)
            expect(
                1.5 <= r_half <= 2.5,
                f"node {nid}: 0x1017 = {base // 2} ms gave {r_half:.2f} beats per {base} ms beat",
            )
            sdo[0x1017].raw = 0
            mark = lab.frames.mark()
            expect(lab.wait_frames(0x700 + _other(nid), 5, since=mark), "the other node stopped beating")
            silent = lab.frames.count(0x700 + nid, mark)
            expect(silent <= 1, f"node {nid}: {silent} heartbeats with 0x1017 = 0")
        finally:
            sdo[0x1017].raw = base
        r_same = _hb_ratio(lab, nid)
        expect(0.5 <= r_same <= 1.5, f"node {nid}: {r_same:.2f} beats per peer beat at equal 0x1017")
        details.append(f"node {nid}: x{r_half:.2f} at half period, 0 when off, x{r_same:.2f} restored")
    return "; ".join(details)


# ------------------------------------------------------------------ NMT
def _sdo_silent(lab: Lab, nid: int) -> bool:
    sdo = lab.sdo(nid)
    old = sdo.RESPONSE_TIMEOUT
    sdo.RESPONSE_TIMEOUT = 0.3
    try:
        sdo.upload(0x1000, 0)
        return False
    except SdoCommunicationError:
        return True
    finally:
        sdo.RESPONSE_TIMEOUT = old


def _nmt_stop(nid: int) -> Callable[[Lab], str]:
    def fn(lab: Lab) -> str:
        mark = lab.frames.mark()
        lab.nmt(STOP, nid)
        expect(lab.wait_heartbeat(nid, STOPPED, since=mark), f"no STOPPED heartbeat of node {nid}")
        quiet = lab.frames.mark()
        expect(_sdo_silent(lab, nid), f"node {nid} answered SDO in STOPPED")
        # the window checked below lasts 5 of the node's own heartbeats (0.5 s), not a wall-clock slot it may
        # have slept through on a loaded machine
        expect(
            wait_for(lambda: lab.heartbeat_states(nid, quiet).count(STOPPED) >= 5, 10),
            f"node {nid} stopped its heartbeat in STOPPED",
        )
        cobs = [c for c, _ in lab.frames.since(quiet)]
        expect(
            not {0x180 + nid, 0x280 + nid, 0x380 + nid, 0x480 + nid} & set(cobs),
            f"a PDO of node {nid} in STOPPED",
        )
        if nid == MASTER:
            expect(0x080 not in cobs, "SYNC produced in STOPPED")
        expect(
            lab.heartbeat_states(nid, quiet) and set(lab.heartbeat_states(nid, quiet)) == {STOPPED},
            "heartbeat in STOPPED",
        )
        lab.nmt(START, nid)
        return recovered(lab)

    return fn


def _nmt_preop(nid: int) -> Callable[[Lab], str]:
    def fn(lab: Lab) -> str:
        mark = lab.frames.mark()
        lab.nmt(ENTER_PREOP, nid)
        expect(
            lab.wait_heartbeat(nid, PRE_OPERATIONAL, since=mark),
            f"no PRE-OPERATIONAL heartbeat of node {nid}",
        )
        if nid == SLAVE:  # the master, NMT master of the pair, starts it again by itself (docs/nodes.md)
            expect(
                wait_for(lambda: (0x000, bytes([START, SLAVE])) in lab.frames.since(mark), 5),
                "the master did not start the pre-operational slave",
            )
            return recovered(lab)
        expect(
            lab.sdo(nid)[0x1000].raw == lab.nodes[nid].object_dictionary[0x1000].default,
            "SDO in PRE-OPERATIONAL",
        )
        current = lab.sdo(nid)["current_A"].raw
        expect(current == 0.0, f"0x2002 current_A = {current} A in PRE-OPERATIONAL (no control: 0 A)")
        quiet = lab.frames.mark()
        expect(lab.wait_frames(0x080, 20, since=quiet), "no SYNC from the master in PRE-OPERATIONAL")
        expect(lab.frames.count(0x180 + nid, quiet) == 0, "a TPDO of the master in PRE-OPERATIONAL")
        lab.nmt(START, nid)
        return recovered(lab)

    return fn


def _nmt_reset(nid: int, command: int) -> Callable[[Lab], str]:
    def fn(lab: Lab) -> str:
        sdo = lab.sdo(nid)
        hb = sdo[0x1017].raw
        sdo[0x1017].raw = hb + 50  # a communication object off its power-on value
        kp = sdo.upload(0x2200, 0)
        low, high = eds_limits(ROLE[nid], 0x2200)
        other_kp = struct.pack("<f", min(high, struct.unpack("<f", kp)[0] + 0.5))
        sdo.download(0x2200, 0, other_kp)  # an application object off the program's value
        mark = lab.frames.mark()
        lab.nmt(command, nid)
        expect(
            wait_for(lambda: (0x700 + nid, b"\x00") in lab.frames.since(mark), 5), f"no boot-up of node {nid}"
        )
        expect(
            lab.wait_heartbeat(nid, PRE_OPERATIONAL, since=mark) or nid == SLAVE,
            f"node {nid} not PRE-OPERATIONAL after the reset",
        )
        expect(sdo[0x1017].raw == hb, f"0x1017 = {sdo[0x1017].raw} after the reset, power-on value {hb}")
        if command == RESET_NODE:
            expect(
                sdo.upload(0x2200, 0) == kp,
                "0x2200 not back to the program's power-on value after reset node",
            )
        else:
            sdo.download(0x2200, 0, kp)  # reset communication keeps it: put it back
        if nid == MASTER:
            lab.nmt(START, nid)
        return recovered(lab)

    return fn


CHECKS: list[Check] = [
    Check("sdo_expedited", "CiA 301 7.2.4 SDO: expedited download and upload", sdo_expedited),
    Check("sdo_segmented", "CiA 301 7.2.4 SDO: segmented download and upload", sdo_segmented),
    Check("sdo_block", "CiA 301 7.2.4 SDO: block upload and download", sdo_block),
    Check(
        "sdo_abort_missing_object",
        "CiA 301 7.2.4 SDO abort codes: 0x06020000 object does not exist",
        sdo_abort_missing_object,
    ),
    Check(
        "sdo_abort_missing_subindex",
        "CiA 301 7.2.4 SDO abort codes: 0x06090011 sub-index does not exist",
        sdo_abort_missing_subindex,
    ),
    Check(
        "sdo_abort_read_only",
        "CiA 301 7.2.4 SDO abort codes: 0x06010002 write to a read-only object",
        sdo_abort_read_only,
    ),
    Check(
        "sdo_abort_out_of_range",
        "CiA 301 7.2.4 SDO abort codes: 0x06090030/31/32 value range",
        sdo_abort_out_of_range,
    ),
    Check("sync_counter", "CiA 301 7.2.5 SYNC with counter; object 0x1019", sync_counter),
    Check(
        "pdo_mapping_procedure",
        "CiA 301 7.5.2.36 PDO mapping procedure; 7.5.2.35 SYNC start value only while invalid",
        pdo_mapping_procedure,
    ),
    Check("sync_start_value", "CiA 301 7.5.2.35 TPDO SYNC start value", sync_start_value),
    Check("sync_length", "CiA 301 7.2.5 SYNC length; EMCY 0x8240", sync_length),
    Check("heartbeat_producer", "CiA 301 7.2.8.3 heartbeat producer; object 0x1017", heartbeat_producer),
    *[
        Check(f"nmt_stop_start_node{n}", "CiA 301 7.3.2 NMT state machine: STOPPED, start", _nmt_stop(n))
        for n in (SLAVE, MASTER)
    ],
    *[
        Check(
            f"nmt_preop_start_node{n}",
            "CiA 301 7.3.2 NMT: PRE-OPERATIONAL (SDO, SYNC, no PDO)",
            _nmt_preop(n),
        )
        for n in (SLAVE, MASTER)
    ],
    *[
        Check(
            f"nmt_reset_communication_node{n}",
            "CiA 301 7.3.2 NMT reset communication: boot-up, 0x1000-0x1FFF power-on",
            _nmt_reset(n, RESET_COMM),
        )
        for n in (SLAVE, MASTER)
    ],
    *[
        Check(
            f"nmt_reset_node_node{n}",
            "CiA 301 7.3.2 NMT reset node: boot-up, every object power-on",
            _nmt_reset(n, RESET_NODE),
        )
        for n in (SLAVE, MASTER)
    ],
]


def run_check(check: Check, lab: Lab) -> dict:
    """One check: {"name", "clause", "result": "PASS"|"FAIL"|"ERROR", "detail"}."""
    try:
        detail = check.fn(lab)
        result = "PASS"
    except CheckFailed as exc:
        detail, result = str(exc), "FAIL"
    except Exception as exc:  # the client could not even talk to the node: a failure too, named as such
        detail, result = f"{type(exc).__name__}: {exc}", "ERROR"
    return {"name": check.name, "clause": check.clause, "result": result, "detail": detail}
