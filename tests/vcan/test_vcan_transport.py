"""The real SocketCAN path: our bus factory on vcan, cross-checked with candump."""

from __future__ import annotations

import can
import pytest

from telethermo.transport.bus import TransportSettings, open_bus

pytestmark = pytest.mark.vcan


def test_socketcan_pair_exchanges_frames_and_candump_sees_them(vcan_channel, candump):
    dump = candump()  # listening
    s = TransportSettings("socketcan", vcan_channel)
    a, b = open_bus(s), open_bus(s)
    try:
        sent = [
            can.Message(arbitration_id=0x181, data=bytes([i, 1, 2, 3, 4, 5, 6, 7]), is_extended_id=False)
            for i in range(20)
        ]
        for m in sent:
            a.send(m)
        got = []
        while len(got) < len(sent):
            m = b.recv(10.0)
            assert m is not None, f"only {len(got)} of {len(sent)} frames arrived"
            got.append(m)
        assert [bytes(m.data) for m in got] == [bytes(m.data) for m in sent]
        assert a.recv(0.2) is None  # no own frames (receive_own_messages off)
    finally:
        a.shutdown()
        b.shutdown()
    seen = dump.stop()
    assert [(i, d) for i, d in seen if i == 0x181] == [(0x181, bytes(m.data)) for m in sent]
