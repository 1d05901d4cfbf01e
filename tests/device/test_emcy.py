"""EMCY producer: codes and register on the bus (canopen's EMCY consumer), 0x1001 and the 0x1003
history (newest first, 8 kept, cleared by writing 0), error reset, inhibit time, STOPPED."""

from __future__ import annotations


import pytest
from canopen import SdoAbortedError

from telethermo.device import NmtCommand
from telethermo.nodes.launch import wait_for


def wait_log(node, n: int, timeout: float = 10.0) -> list:
    wait_for(lambda: len(node.emcy.log) >= n, timeout, poll_s=0.005)
    return list(node.emcy.log)


def history(node) -> list[int]:
    n = node.sdo["Pre-defined error field"][0].raw
    return [node.sdo["Pre-defined error field"][i].raw for i in range(1, n + 1)]


def test_emcy_codes_register_and_history_newest_first(lab):
    dev = lab.device("master")
    node = lab.client("master")
    node.sdo["Inhibit time EMCY"].raw = 0
    dev.raise_emcy(0x4210, data=b"\x2a")  # temperature
    dev.raise_emcy(0x2310)  # current
    dev.raise_emcy(0xFF01)  # manufacturer
    log = wait_log(node, 3)
    assert [(e.code, e.register) for e in log] == [(0x4210, 0x09), (0x2310, 0x0B), (0xFF01, 0x8B)]
    assert log[0].data[:1] == b"\x2a"
    assert node.sdo["Error register"].raw == 0x8B
    assert history(node) == [0xFF01, 0x2310, 0x4210]
    dev.clear_emcy(0x2310)
    dev.clear_emcy(0x4210)
    assert node.sdo["Error register"].raw == 0x81
    dev.clear_emcy(0xFF01)  # the last one: error reset
    log = wait_log(node, 4)
    assert (log[-1].code, log[-1].register) == (0x0000, 0x00)
    assert node.sdo["Error register"].raw == 0
    assert history(node) == [0xFF01, 0x2310, 0x4210]  # the history stays until cleared


def test_history_keeps_the_8_newest_and_is_cleared_by_writing_zero(lab):
    dev = lab.device("slave")
    node = lab.client("slave")
    for k in range(11):
        dev.raise_emcy(0x5000 + k)
    assert history(node) == [0x5000 + k for k in range(10, 2, -1)]
    with pytest.raises(SdoAbortedError) as exc:
        node.sdo["Pre-defined error field"][0].raw = 3
    assert exc.value.code == 0x06090030
    node.sdo["Pre-defined error field"][0].raw = 0
    assert history(node) == [] and node.sdo["Pre-defined error field"][1].raw == 0
    with pytest.raises(SdoAbortedError) as exc:
        node.sdo["Pre-defined error field"][1].raw = 0x1234  # entries are read-only
    assert exc.value.code == 0x06010002


def test_inhibit_time_spaces_emcy_frames_without_losing_them(lab):
    dev = lab.device("master")
    node = lab.client("master")
    node.sdo["Inhibit time EMCY"].raw = 1500  # 150 ms
    for code in (0x4210, 0x4220, 0x4230):
        dev.raise_emcy(code)
    dev.raise_emcy(0x4230)  # already waiting: not queued twice
    log = wait_log(node, 3)
    assert [e.code for e in log] == [0x4210, 0x4220, 0x4230]
    gaps = [b.timestamp - a.timestamp for a, b in zip(log, log[1:])]
    assert min(gaps) >= 0.14  # never closer than the inhibit time (a lower bound load cannot break)
    assert history(node)[:4] == [0x4230, 0x4230, 0x4220, 0x4210]  # every occurrence is in the history


def test_stopped_records_but_does_not_send(lab):
    dev = lab.device("master")
    node = lab.client("master")
    dev.nmt_command(NmtCommand.STOP, 1)
    dev.raise_emcy(0x4210)
    dev.nmt_command(NmtCommand.ENTER_PRE_OPERATIONAL, 1)
    assert node.sdo["Error register"].raw == 0x09 and history(node) == [0x4210]
    dev.raise_emcy(0x3210)
    log = wait_log(node, 1)
    assert [e.code for e in log] == [0x3210]
    assert dev.stats.emcy_suppressed == 1


def test_reset_node_clears_errors_and_history(lab):
    dev = lab.device("master")
    node = lab.client("master")
    dev.raise_emcy(0x4210)
    node.nmt.state = "RESET"
    node.nmt.wait_for_bootup(2.0)
    assert node.sdo["Error register"].raw == 0 and history(node) == []
    assert dev.active_errors == ()
