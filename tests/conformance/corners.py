"""CiA 301 conformance checks of the live pair, second part: PDO transmission types counted by the slave's
cycles, EMCY consistency with one EMCY per lost node, and the protocol corners of issue 25 (segmented SDO
refused at the initiate and timed out, 0x1006, RPDO timeout, the SYNC counter after STOPPED). Same client
and rules as tests/conformance/checks.py (canopen's RemoteNode/SdoClient/NmtMaster from the shipped EDS
files, raw frames); :data:`SUITE` is the whole suite in its order.

What the checks assert is what CiA 301 and docs/canopen.md promise, never the order in which a loaded machine
happens to put frames on the hub: a TPDO of SYNC k may reach the bus after SYNC k+1 (the slave processed SYNC
k late), so the transmission types are counted in the slave's own cycles (0x2702 mapped into the TPDO).
"""

from __future__ import annotations

import struct
import threading

from telethermo.cia301 import (
    ABORT_COMMAND_SPECIFIER,
    ABORT_LENGTH_HIGH,
    ABORT_LOCAL_CONTROL,
    ABORT_NO_OBJECT,
    ABORT_NO_SUBINDEX,
    ABORT_READ_ONLY,
    ABORT_TIMEOUT,
    EMCY_HEARTBEAT,
    EMCY_RPDO_TIMEOUT,
)

from tests.conformance.checks import (
    CHECKS,
    OPERATIONAL,
    PEER_LOST_BIT,
    START,
    STOP,
    STOPPED,
    Check,
    _abort,
    _remap,
    expect,
    recovered,
)
from tests.conformance.lab import MASTER, SLAVE, Lab, wait_for

CYCLE_COUNTER_MAP = 0x27020020  # 0x2702 cycle_counter, 32 bits


def _cycles_between_tpdo2(lab: Lab, mark: int) -> list[int]:
    """Differences of the slave's cycle_counter between consecutive TPDO2 frames since ``mark``."""
    counts = [
        int.from_bytes(d[:4], "little") for c, d in lab.frames.since(mark) if c == 0x282 and len(d) == 4
    ]
    return [b - a for a, b in zip(counts, counts[1:])]


def pdo_transmission_types(lab: Lab) -> str:
    """The slave's TPDO2, mapped to its cycle_counter (one count per SYNC it runs a cycle for), at type 1
    comes once per SYNC (consecutive frames 1 cycle apart), at type 10 once per 10 SYNCs (10 apart)."""
    sdo = lab.sdo(SLAVE)
    saved = [sdo[0x1A01][i].raw for i in range(1, sdo[0x1A01][0].raw + 1)]
    trans = sdo[0x1801][2].raw
    _remap(sdo, 0x1801, 0x1A01, [CYCLE_COUNTER_MAP])
    try:
        sdo[0x1801][2].raw = 1
        mark = lab.frames.mark()
        expect(lab.wait_frames(0x282, 42, since=mark), "TPDO2 at type 1 does not come")
        every = _cycles_between_tpdo2(lab, mark)[1:41]  # the first one may be the old type's
        sdo[0x1801][2].raw = 10
        mark = lab.frames.mark()
        expect(lab.wait_frames(0x282, 7, since=mark), "TPDO2 at type 10 does not come")
        tenth = _cycles_between_tpdo2(lab, mark)[2:6]  # the switch's countdown may be shorter
    finally:
        sdo[0x1801][2].raw = trans
        _remap(sdo, 0x1801, 0x1A01, saved)
    expect(
        set(every) == {1} and set(tenth) == {10},
        f"slave cycles between TPDO2 frames: type 1 {sorted(set(every))}, type 10 {sorted(set(tenth))}",
    )
    return f"type 1: every SYNC ({len(every)} intervals); type 10: every 10th ({len(tenth)})"


class _FakeNode:
    """Heartbeats of a node that does not exist (raw frames, state OPERATIONAL) every 50 ms while ``on``."""

    def __init__(self, lab: Lab, node_id: int) -> None:
        self.lab, self.node_id = lab, node_id
        self.on, self._stop = threading.Event(), threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(0.05):
            if self.on.is_set():
                self.lab.net.send_message(0x700 + self.node_id, bytes([OPERATIONAL]))

    def close(self) -> None:
        self._stop.set()
        self._thread.join(1.0)


class _Sampler:
    """0x1001 of the master against what is active: latched trips (0x2706), the link-loss fallback (0x2619,
    EMCY 0xFF01), lost watched nodes (0x2705). A sample counts when the trips did not change during it."""

    def __init__(self, sdo) -> None:
        self.sdo, self.bad, self.samples = sdo, [], 0

    def __call__(self) -> int:
        sdo = self.sdo
        t1, fb, alive = sdo["active_trips"].raw, sdo["link_fallback_active"].raw, sdo["peer_alive"].raw
        reg, t2 = sdo[0x1001].raw, sdo["active_trips"].raw
        if t1 == t2 and fb == sdo["link_fallback_active"].raw:
            self.samples += 1
            wrong = (
                (t1 and not reg & 0x01)
                or (t1 & PEER_LOST_BIT and reg & 0x11 != 0x11)
                or (fb and reg & 0x81 != 0x81)
                or (not t1 and not fb and alive and reg)
            )
            if wrong:
                self.bad.append((t1, fb, alive, reg))
        return t2


def emcy_consistency(lab: Lab) -> str:
    """0x1001/0x1003/EMCY of the master against its latched trips (0x2706) at every sample, while the
    heartbeat consumer and the trip share EMCY 0x8130. The link-loss fallback is switched off (0x2618 = 0):
    the peer trip comes at once. Stop the slave (its heartbeat goes on, its PDOs stop): the master trips
    peer_lost (one EMCY 0x8130 naming node 2). Meanwhile an unrelated node 5 watched by 0x1016 sub 2 is lost
    (its own EMCY 0x8130 naming node 5: a monitor learns it is gone), comes back (0x8130 stays: the trip is
    latched), is lost again (a second EMCY for node 5) and its entry is removed (its error goes). NMT start
    of the slave: the trip clears itself, one error-reset EMCY, 0x1001 = 0."""
    master = lab.sdo(MASTER)
    sample = _Sampler(master)

    def alive_is(value: bool) -> bool:
        sample()
        return master["peer_alive"].raw is value

    fake = _FakeNode(lab, 5)
    render_s = master["link_loss_render_s"].raw
    try:
        master["link_loss_render_s"].raw = 0.0
        fake.on.set()
        master[0x1016][2].raw = (5 << 16) | 300
        expect(wait_for(lambda: alive_is(True), 10, 0.05), "node 5 not seen by the master's consumer")
        mark = lab.frames.mark()
        lab.nmt(STOP, SLAVE)
        expect(wait_for(lambda: sample() & PEER_LOST_BIT, 30, 0.05), "the master never tripped peer_lost")
        for _ in range(2):
            fake.on.clear()  # node 5 lost
            expect(wait_for(lambda: alive_is(False), 10, 0.05), "node 5's loss not seen (0x2705)")
            fake.on.set()  # node 5 back: the trip is still latched
            expect(wait_for(lambda: alive_is(True), 10, 0.05), "node 5's return not seen (0x2705)")
            for _ in range(5):
                sample()
        fake.on.clear()
        expect(wait_for(lambda: alive_is(False), 10, 0.05), "node 5's third loss not seen")
        master[0x1016][2].raw = 0  # no longer watched: its error goes
        for _ in range(10):
            sample()
        expect(master[0x1003][1].raw & 0xFFFF == EMCY_HEARTBEAT, "0x1003 newest entry is not 0x8130")
        lab.nmt(START, SLAVE)
        expect(wait_for(lambda: sample() == 0, 30, 0.05), "the peer_lost trip did not clear after NMT start")
        expect(
            wait_for(lambda: master[0x1001].raw == 0, 10, 0.05),
            f"0x1001 = 0x{master[0x1001].raw:02X} with no trip latched and no watched node lost",
        )
        for _ in range(5):
            sample()
    finally:
        fake.close()
        master[0x1016][2].raw = 0
        master["link_loss_render_s"].raw = render_s
    expect(
        not sample.bad,
        f"0x1001 disagreed with what is active (trips, fallback, alive, 0x1001): {sample.bad[:5]}",
    )
    # 0x1001 = 0 comes with the error-reset EMCY, but that frame may still be on its way to the test's
    # listener (EMCY inhibit time 0x1015, the hub, its reader thread): wait for it before reading the EMCYs
    wait_for(lambda: lab.emcy_codes(MASTER, mark)[-1:] == [0x0000], 10, 0.05)
    frames = [d for c, d in lab.frames.since(mark) if c == 0x80 + MASTER and len(d) == 8]
    hb_nodes = [d[3] for d in frames if int.from_bytes(d[:2], "little") == EMCY_HEARTBEAT]
    expect(
        sorted(hb_nodes) == [2, 5, 5, 5],
        f"EMCY 0x8130 naming nodes {hb_nodes} (want the peer once, node 5 once per loss)",
    )
    codes = [int.from_bytes(d[:2], "little") for d in frames]
    expect(codes[-1] == 0x0000 and codes.count(0x0000) == 1, f"master EMCYs {[hex(c) for c in codes]}")
    recovered(lab)
    return f"{sample.samples} consistent samples; EMCY 0x8130 for nodes {hb_nodes}; then error reset"


# ------------------------------------------------------------------ protocol corners (issue 25)
def _sdo_raw(lab: Lab, nid: int, data: bytes, timeout_s: float = 5.0) -> bytes | None:
    """One raw request on 0x600+id; the first answer on 0x580+id after it (None: none within timeout)."""
    mark = lab.frames.mark()
    lab.net.send_message(0x600 + nid, data.ljust(8, b"\x00"))
    found: list[bytes] = []

    def answered() -> bool:
        found[:] = [d for c, d in lab.frames.since(mark) if c == 0x580 + nid][:1]
        return bool(found)

    return found[0] if wait_for(answered, timeout_s) else None


def _abort_of(answer: bytes | None) -> int | None:
    return struct.unpack_from("<L", answer, 4)[0] if answer and answer[0] == 0x80 else None


def sdo_segmented_initiate(lab: Lab) -> str:
    """A segmented download that cannot succeed is aborted in answer to its initiate (CANopenNode does)."""
    cases = [
        (0x5FFF, 0, 4, ABORT_NO_OBJECT),
        (0x1018, 9, 4, ABORT_NO_SUBINDEX),
        (0x1000, 0, 4, ABORT_READ_ONLY),
        (0x2200, 0, 8, ABORT_LENGTH_HIGH),
    ]
    for nid in (MASTER, SLAVE):
        kp = lab.sdo(nid).upload(0x2200, 0)
        for index, sub, size, want in cases:
            answer = _sdo_raw(lab, nid, bytes([0x21]) + struct.pack("<HBL", index, sub, size))
            got = _abort_of(answer)
            expect(
                got == want,
                f"node {nid}: initiate segmented download of 0x{index:04X} sub {sub}, "
                f"{size} bytes: answer {answer and answer.hex()}, want abort 0x{want:08X}",
            )
        expect(lab.sdo(nid).upload(0x2200, 0) == kp, f"node {nid}: 0x2200 changed")
    return "0x06020000, 0x06090011, 0x06010002, 0x06070012 at the initiate"


def sdo_segmented_timeout(lab: Lab) -> str:
    """A segmented download left open is aborted with 0x05040000; a segment after it finds no transfer."""
    for nid in (MASTER, SLAVE):
        kp = lab.sdo(nid).upload(0x2200, 0)
        answer = _sdo_raw(lab, nid, bytes([0x21]) + struct.pack("<HBL", 0x2200, 0, 4))
        expect(
            answer is not None and answer[0] == 0x60,
            f"node {nid}: initiate answered {answer and answer.hex()}",
        )
        mark = lab.frames.mark()
        expect(
            wait_for(lambda: any(c == 0x580 + nid for c, _ in lab.frames.since(mark)), 10),
            f"node {nid}: the open transfer was never aborted",
        )
        late = next(d for c, d in lab.frames.since(mark) if c == 0x580 + nid)
        expect(_abort_of(late) == ABORT_TIMEOUT, f"node {nid}: {late.hex()} instead of abort 0x05040000")
        seg = _abort_of(_sdo_raw(lab, nid, bytes([0x01 | 3 << 1]) + kp))
        expect(
            seg == ABORT_COMMAND_SPECIFIER,
            f"node {nid}: a segment after the timeout: abort {seg and hex(seg)}",
        )
        expect(lab.sdo(nid).upload(0x2200, 0) == kp, f"node {nid}: 0x2200 changed")
    return "0x05040000 after the server timeout, then 0x05040001 for the late segment"


def sync_period_1006(lab: Lab) -> str:
    """0x1006 keeps the configured period; another value is refused with 0x08000021 (docs/canopen.md)."""
    for nid in (MASTER, SLAVE):
        sdo = lab.sdo(nid)
        period = sdo[0x1006].raw
        for value in (0, period + 1000):
            code = _abort(lambda: setattr(sdo[0x1006], "raw", value))
            expect(code == ABORT_LOCAL_CONTROL, f"node {nid}: 0x1006 = {value}: abort {code and hex(code)}")
        sdo[0x1006].raw = period
        expect(sdo[0x1006].raw == period, f"node {nid}: 0x1006 changed")
    return f"0x08000021 for another period; the configured {period} us accepted"


def rpdo_timeout(lab: Lab) -> str:
    """Master's RPDO1 event timer 500 ms, monitored from the next RPDO1: the slave stopped, its TPDO1 stops:
    EMCY 0x8250 naming RPDO1 beside the peer trip; the slave started: the next RPDO clears it; timer back to
    0, the pair recovers."""
    master = lab.sdo(MASTER)
    mark = lab.frames.mark()
    try:
        master[0x1400][5].raw = 500
        # monitoring starts at the first RPDO after the write (CANopenNode): let a few come first
        expect(lab.wait_frames(0x182, 3, since=lab.frames.mark()), "the slave's TPDO1 does not flow")
        lab.nmt(STOP, SLAVE)
        expect(
            wait_for(lambda: EMCY_RPDO_TIMEOUT in lab.emcy_codes(MASTER, mark), 20),
            f"no EMCY 0x8250 (master EMCYs {[hex(c) for c in lab.emcy_codes(MASTER, mark)]}, 0x1001 = "
            f"0x{master[0x1001].raw:02X}, 0x1003:1 = 0x{master[0x1003][1].raw:08X}, 0x1400:5 = "
            f"{master[0x1400][5].raw}, slave TPDO1 since: {lab.frames.count(0x182, mark)})",
        )
        data = next(d for c, d in lab.frames.since(mark) if c == 0x81 and d[:2] == b"\x50\x82")
        expect(data[3] == 1 and data[2] & 0x11 == 0x11, f"EMCY 0x8250 {data.hex()}: byte 3 not RPDO 1")
        lab.nmt(START, SLAVE)
        expect(lab.wait_frames(0x182, 5, since=mark), "the slave's TPDO1 does not come back")
    finally:
        master[0x1400][5].raw = 0
        lab.nmt(START, SLAVE)  # (again, if the check failed before: the next check finds the pair running)
    codes = lab.emcy_codes(MASTER, mark)
    return f"master EMCYs {[f'0x{c:04X}' for c in codes]}; {recovered(lab)}"


def sync_counter_after_stop(lab: Lab) -> str:
    """The producer stopped and started again: its next SYNC carries counter 1 (CANopenNode)."""
    mark = lab.frames.mark()
    lab.nmt(STOP, MASTER)
    expect(lab.wait_heartbeat(MASTER, STOPPED, since=mark), "no STOPPED heartbeat of the master")
    quiet = lab.frames.mark()
    lab.nmt(START, MASTER)
    expect(lab.wait_frames(0x80, 3, since=quiet), "no SYNC after NMT start")
    counters = [d[0] for c, d in lab.frames.since(quiet) if c == 0x80 and len(d) == 1]
    expect(counters[:3] == [1, 2, 3], f"SYNC counters after the start: {counters[:3]}")
    return f"SYNC counters {counters[:3]} after the start; {recovered(lab)}"


CORNERS: list[Check] = [
    Check(
        "sdo_segmented_initiate",
        "CiA 301 7.2.4.3.3 SDO download initiate: refused before any segment",
        sdo_segmented_initiate,
    ),
    Check(
        "sdo_segmented_timeout",
        "CiA 301 7.2.4.3.17 SDO abort 0x05040000: segmented transfer timed out",
        sdo_segmented_timeout,
    ),
    Check("sync_period_1006", "CiA 301 object 0x1006 communication cycle period", sync_period_1006),
    Check("rpdo_timeout", "CiA 301 RPDO event timer (0x1400 sub 5); EMCY 0x8250", rpdo_timeout),
    Check("sync_counter_after_stop", "CiA 301 7.2.5 SYNC counter after NMT STOPPED", sync_counter_after_stop),
]


def _suite() -> list[Check]:
    names = [c.name for c in CHECKS]
    out = list(CHECKS)
    out.insert(
        names.index("pdo_mapping_procedure") + 1,
        Check(
            "pdo_transmission_types",
            "CiA 301 7.2.2 PDO transmission types (synchronous, every n-th SYNC)",
            pdo_transmission_types,
        ),
    )
    at = [c.name for c in out].index("heartbeat_producer") + 1
    out.insert(
        at,
        Check(
            "emcy_consistency",
            "CiA 301 7.2.7 EMCY, 7.2.8.3 heartbeat consumer; objects 0x1001, 0x1003, 0x1016",
            emcy_consistency,
        ),
    )
    for i, check in enumerate(CORNERS):
        out.insert(at + 1 + i, check)
    return out


#: every check, in the order they run on one pair
SUITE: list[Check] = _suite()
