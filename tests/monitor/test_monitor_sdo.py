"""SDO decoding: one state machine per node, every transfer type of CiA 301 §7.2.4."""

from __future__ import annotations

import struct


from telethermo.monitor.sdo import SdoChannel
from telethermo.monitor.state import Monitor

from .conftest import monitor_config


def _run(ch: SdoChannel, frames):
    """Feed (from_client, bytes) pairs; return the finished transfers and the problems."""
    done, problems = [], []
    for i, (client, data) in enumerate(frames):
        step = ch.request(float(i), bytes(data)) if client else ch.response(float(i), bytes(data))
        if step.done:
            done.append(step.done)
        if step.problem:
            problems.append(step.problem)
    return done, problems


def _pad(b: bytes) -> bytes:
    return b + bytes(8 - len(b))


def test_block_download_with_partial_ack_and_retransmission():
    payload = bytes(range(1, 18))  # 17 bytes: segments of 7, 7, 3
    frames = [
        (True, _pad(bytes([0xC6]) + struct.pack("<HBL", 0x2310, 1, len(payload)))),  # initiate, size
        (False, _pad(bytes([0xA4]) + struct.pack("<HBB", 0x2310, 1, 127))),  # blksize 127
        (True, bytes([0x01]) + payload[0:7]),
        (True, bytes([0x02]) + payload[7:14]),
        (True, _pad(bytes([0x83]) + payload[14:17])),  # last segment (c=1), seq 3
        (False, _pad(bytes([0xA2, 1, 127]))),  # only seq 1 received: resend from seq 2
        (True, bytes([0x01]) + payload[7:14]),  # new sub-block restarts at seq 1
        (True, _pad(bytes([0x82]) + payload[14:17])),
        (False, _pad(bytes([0xA2, 2, 127]))),
        (True, _pad(bytes([0xC1 | (4 << 2)]) + b"\x00\x00")),  # end: 4 bytes of the last segment unused
        (False, _pad(bytes([0xA1]))),
    ]
    done, problems = _run(SdoChannel(1), frames)
    assert problems == []
    (tr,) = done
    assert (tr.direction, tr.mode, tr.status, tr.index, tr.subindex) == ("download", "block", "ok", 0x2310, 1)
    assert tr.data == payload and tr.size == 17


def test_block_upload():
    payload = b"telethermo slave"  # 16 bytes: 7, 7, 2
    frames = [
        (True, _pad(bytes([0xA4]) + struct.pack("<HBBB", 0x1008, 0, 127, 0))),
        (False, _pad(bytes([0xC6]) + struct.pack("<HBL", 0x1008, 0, len(payload)))),
        (True, _pad(bytes([0xA3]))),
        (False, bytes([0x01]) + payload[0:7]),
        (False, bytes([0x02]) + payload[7:14]),
        (False, _pad(bytes([0x83]) + payload[14:16])),
        (True, _pad(bytes([0xA2, 3, 127]))),
        (False, _pad(bytes([0xC1 | (5 << 2)]) + b"\x00\x00")),
        (True, _pad(bytes([0xA1]))),
    ]
    done, problems = _run(SdoChannel(2), frames)
    assert problems == []
    (tr,) = done
    assert (tr.direction, tr.mode, tr.status, tr.data, tr.size) == ("upload", "block", "ok", payload, 16)


def test_toggle_error_and_client_abort_are_reported():
    frames = [
        (True, _pad(bytes([0x40]) + struct.pack("<HB", 0x1008, 0))),
        (False, _pad(bytes([0x41]) + struct.pack("<HBL", 0x1008, 0, 17))),
        (True, _pad(bytes([0x60]))),
        (False, bytes([0x10]) + b"abcdefg"),  # toggle 1 where 0 was due
    ]
    done, problems = _run(SdoChannel(1), frames)
    assert len(done) == 1 and done[0].status == "error" and "toggle" in done[0].problem
    assert problems and "toggle" in problems[0]
    frames = [
        (True, _pad(bytes([0x40]) + struct.pack("<HB", 0x1008, 0))),
        (True, struct.pack("<BHBL", 0x80, 0x1008, 0, 0x05040000)),
    ]
    done, _ = _run(SdoChannel(1), frames)
    assert (done[0].status, done[0].aborted_by, done[0].abort_code, done[0].abort_text) == (
        "aborted",
        "client",
        0x05040000,
        "SDO protocol timed out",
    )


def test_unexpected_segment_without_transfer_is_a_problem_not_a_crash():
    done, problems = _run(SdoChannel(1), [(False, bytes([0x00]) + b"1234567")])
    assert done == [] and len(problems) == 1
    assert problems[0].startswith("unexpected upload segment response")


def test_server_switching_block_upload_to_normal_upload(canbus):
    """canopen's SdoServer answers a block upload with a normal upload (allowed by CiA 301)."""
    canbus.exchange(1, _pad(bytes([0xA4]) + struct.pack("<HBBB", 0x1008, 0, 127, 0)))
    for t in (0x60, 0x70, 0x60):  # each request only after the response to the previous one
        canbus.exchange(1, _pad(bytes([t])))
    msgs = canbus.wait_frames(8)
    assert len(msgs) == 8
    mon = Monitor(monitor_config())
    for m in msgs:
        mon.feed(m)
    (rec,) = mon.nodes[1].sdo_transfers
    assert rec.transfer.status == "ok" and rec.transfer.mode == "segmented"
    assert rec.value == canbus.master.sdo[0x1008].raw and rec.name == "Manufacturer device name"


def test_two_nodes_interleaved_transfers_decode_independently(canbus):
    """Segmented uploads from both real servers at once, the two conversations interleaved frame by
    frame on the bus (the client side driven by hand): one state machine per node keeps them apart.
    Each request goes out only once the server has answered the previous one on its channel (CiA 301:
    one outstanding request per channel), so the bus order is 601 581 602 582 601 581 ... however
    slowly the server threads run; a fixed sleep there let a slow server fall behind and the client
    send a segment request before the previous response, which is a protocol error (and the monitor
    reports it as one)."""

    def req(node, data):
        canbus.exchange(node, _pad(bytes(data)))

    req(1, [0x40, 0x08, 0x10, 0x00])  # initiate upload 0x1008 on node 1
    req(2, [0x40, 0x08, 0x10, 0x00])  # ... and on node 2 before node 1's segments
    for toggle in (0x60, 0x70, 0x60):  # 17 bytes = 3 segments each, alternating nodes
        req(1, [toggle])
        req(2, [toggle])
    msgs = canbus.wait_frames(16)
    ids = [m.arbitration_id for m in msgs]
    assert len(ids) == 16
    assert ids == [0x601, 0x581, 0x602, 0x582] * 4  # really interleaved, frame by frame
    mon = Monitor(monitor_config())
    for m in msgs:
        mon.feed(m)
    for n, dev in ((1, canbus.master), (2, canbus.slave)):
        (rec,) = mon.nodes[n].sdo_transfers
        assert rec.transfer.status == "ok" and rec.transfer.mode == "segmented"
        assert rec.value == dev.sdo[0x1008].raw
    assert mon.log.counts["WARN"] == 0
