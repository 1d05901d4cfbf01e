"""``telethermo sdo``: generic SDO access to a node that is not ours and has no EDS (a canopen LocalNode
with a hand-built dictionary, node-ID 5, beside our two devices on a virtual bus): upload as raw bytes
or typed, download typed, aborts with their CiA 301 text, a silent node, bad arguments."""

from __future__ import annotations

import canopen
import pytest
from canopen.objectdictionary import ODVariable
from canopen.objectdictionary.datatypes import UNSIGNED16, UNSIGNED32, VISIBLE_STRING

from telethermo.cli.main import EXIT_FAIL, EXIT_OK, EXIT_USAGE

FOREIGN_ID = 5


def _var(index, name, data_type, access, default):
    v = ODVariable(name, index, 0)
    v.data_type, v.access_type, v.default = data_type, access, default
    return v


@pytest.fixture
def foreign(nodes):
    """A thermocouple amplifier of another vendor: node 5, no EDS on the operator's side."""
    od = canopen.ObjectDictionary()
    od.add_object(_var(0x1000, "Device type", UNSIGNED32, "ro", 0x00040191))
    od.add_object(_var(0x1008, "Manufacturer device name", VISIBLE_STRING, "const", "TC-amp 8"))
    od.add_object(_var(0x2000, "gain", UNSIGNED32, "rw", 42))
    od.add_object(_var(0x2001, "filter", UNSIGNED16, "rw", 3))
    nw = canopen.Network()
    nw.NOTIFIER_CYCLE = 0.05
    nw.connect(interface="virtual", channel=nodes.channel)
    node = canopen.LocalNode(FOREIGN_ID, od)
    nw.add_node(node)
    try:
        yield node
    finally:
        nw.disconnect()


def test_upload_of_a_node_without_eds(nodes, foreign, cli):
    code, out, err = cli("sdo", *nodes.bus, "5", "0x2000")
    assert code == EXIT_OK, err
    assert out == "node 5 0x2000:00 = 2a 00 00 00 (4 bytes; as u32 42 = 0x0000002A)\n"
    code, out, err = cli("sdo", *nodes.bus, "5", "1008")  # segmented (8 bytes), hex index without 0x
    assert code == EXIT_OK, err
    u64 = int.from_bytes(b"TC-amp 8", "little")
    assert (
        out == f"node 5 0x1008:00 = 54 43 2d 61 6d 70 20 38 (8 bytes; as u64 {u64} = 0x{u64:016X}; "
        "as text 'TC-amp 8')\n"
    )
    code, out, _ = cli("sdo", *nodes.bus, "0x05", "0x1000:0", "--type", "u32")
    assert out == "node 5 0x1000:00 = 262545 (0x00040191)\n"
    code, out, _ = cli("sdo", *nodes.bus, "5", "0x1008", "--type", "str")
    assert out == "node 5 0x1008:00 = 'TC-amp 8'\n"


def test_download_typed(nodes, foreign, cli):
    code, out, err = cli("sdo", *nodes.bus, "5", "0x2001", "0x1F4", "--type", "u16")
    assert code == EXIT_OK, err
    assert out == "node 5 0x2001:00 <- f4 01 (UNSIGNED16 0x1F4): written\n"
    assert foreign.sdo.upload(0x2001, 0) == b"\xf4\x01"
    assert cli("sdo", *nodes.bus, "5", "0x2001", "--type", "u16")[1] == "node 5 0x2001:00 = 500 (0x01F4)\n"
    # the size is the type's: a u8 sent to a 16-bit object is the node's to refuse (canopen's LocalNode takes
    # it)
    code, _, err = cli("sdo", *nodes.bus, "5", "0x2001", "7")
    assert (
        code == EXIT_USAGE
        and err
        == "telethermo sdo: error: node 5 0x2001:00: give --type "
        "(u8|u16|u32|u64|i8|i16|i32|i64|f32|f64|str) to write: no EDS for this node\n"
    )


def test_aborts_with_their_cia301_text(nodes, foreign, cli):
    code, out, err = cli("sdo", *nodes.bus, "5", "0x3000")
    assert code == EXIT_FAIL and out == ""
    assert (
        err == "telethermo sdo: node 5 0x3000:00: read refused: SDO abort 0x06020000: "
        "Object does not exist in the object dictionary\n"
    )
    code, _, err = cli("sdo", *nodes.bus, "5", "0x1000", "1", "--type", "u32")
    assert code == EXIT_FAIL
    assert (
        err == "telethermo sdo: node 5 0x1000:00: write refused: SDO abort 0x06010002: "
        "Attempt to write a read only object\n"
    )


def test_our_node_through_its_eds(nodes, cli):
    code, out, err = cli("sdo", *nodes.bus, "slave", "0x1017")
    assert code == EXIT_OK, err
    assert out == "slave 0x1017:00 Producer heartbeat time = 100 ms\n"
    code, out, err = cli(
        "sdo", *nodes.bus, "1", "0x2200", "0.75"
    )  # the EDS type (REAL32), not range-checked here
    assert code == EXIT_OK and out == "master 0x2200:00 kp_A_per_C <- 00 00 40 3f (REAL32 0.75): written\n", (
        err
    )
    assert nodes.devices["master"].read("kp_A_per_C") == pytest.approx(0.75)


def test_silent_node_and_bad_arguments(nodes, cli):
    code, _, err = cli("sdo", *nodes.bus, "--timeout", "0.2", "99", "0x1000")
    assert code == EXIT_FAIL and err.startswith(
        "telethermo sdo: node 99 0x1000:00: no answer (SDO timeout 0.2 s; is node 99 on the bus?)"
    )
    for argv, expected in [
        (["0", "0x1000"], "node '0': expected a node-ID 1..127 or one of master, slave"),
        (["128", "0x1000"], "node '128': expected a node-ID 1..127"),
        (["5", "0x12345"], "object '0x12345': expected INDEX[:SUB]"),
        (["5", "0x1000:256"], "object '0x1000:256': expected INDEX[:SUB]"),
        (["5", "0x2000", "300", "--type", "u8"], "value 300: does not fit a UNSIGNED8 (0..255)"),
        (["5", "0x2000", "-1", "--type", "u32"], "value -1: does not fit a UNSIGNED32"),
        (["5", "0x2000", "1.5", "--type", "i16"], "value '1.5': expected a whole number for a INTEGER16"),
        (["5", "0x2000", "é", "--type", "str"], "value 'é': expected ASCII text"),
    ]:
        code, out, err = cli("sdo", *nodes.bus, *argv)
        assert code == EXIT_USAGE and out == "" and err.count("\n") == 1, argv
        assert expected in err, (argv, err)
