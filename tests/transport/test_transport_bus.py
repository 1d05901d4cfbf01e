"""The bus factory: settings from a table or a string, clear errors, and real buses opened by
configuration."""

from __future__ import annotations

import can
import pytest

from telethermo.transport.bus import (
    TransportError,
    TransportSettings,
    bus_load,
    frame_bits,
    open_bus,
    parse_bus_string,
    settings_from_mapping,
)
from telethermo.transport.hub import HubThread


def test_parse_strings():
    s = parse_bus_string("socketcand://127.0.0.1:29536/vcan0")
    assert (s.interface, s.host, s.port, s.channel) == ("socketcand", "127.0.0.1", 29536, "vcan0")
    assert parse_bus_string(s.describe()) == s
    v = parse_bus_string("virtual:tt")
    assert (v.interface, v.channel) == ("virtual", "tt")
    assert parse_bus_string("socketcan:vcan0").describe() == "socketcan:vcan0"


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("vcan0", "INTERFACE:CHANNEL"),
        ("socketcand://127.0.0.1/vcan0", "HOST:PORT"),
        ("socketcand://127.0.0.1:x/vcan0", "not an integer"),
        ("socketcand://127.0.0.1:70000/vcan0", "bus.port"),
    ],
)
def test_bad_strings_name_the_problem(text, fragment):
    with pytest.raises(TransportError, match=fragment) as info:
        parse_bus_string(text)
    assert "--bus" in str(info.value)


def test_table_errors_name_file_and_field():
    with pytest.raises(TransportError, match=r"network.toml: bus.channel: missing"):
        settings_from_mapping({"interface": "socketcan"}, "network.toml")
    with pytest.raises(TransportError, match=r"network.toml: bus.bitrate: expected an integer"):
        settings_from_mapping(
            {"interface": "socketcan", "channel": "vcan0", "bitrate": "fast"}, "network.toml"
        )
    with pytest.raises(TransportError, match=r"network.toml: bus.hots: unknown field"):
        settings_from_mapping({"interface": "socketcan", "channel": "vcan0", "hots": "x"}, "network.toml")
    with pytest.raises(TransportError, match=r"bus.host: socketcand needs"):
        settings_from_mapping({"interface": "socketcand", "channel": "vcan0", "port": 1}, "network.toml")
    s = settings_from_mapping(
        {
            "interface": "socketcand",
            "channel": "vcan0",
            "options": {"host": "127.0.0.1", "port": 29536, "tcp_tune": True},
        },
        "network.toml",
    )
    assert (s.host, s.port, dict(s.options)) == ("127.0.0.1", 29536, {"tcp_tune": True})


def _exchange(a: can.BusABC, b: can.BusABC) -> None:
    msg = can.Message(arbitration_id=0x181, data=b"\x01\x02\x03\x04", is_extended_id=False)
    a.send(msg)
    got = b.recv(5.0)
    assert got is not None and got.arbitration_id == 0x181 and bytes(got.data) == b"\x01\x02\x03\x04"
    assert a.recv(0.2) is None  # a bus never gives a node its own frame


def test_open_virtual_bus_pair():
    s = TransportSettings("virtual", "test_bus_factory")
    a, b = open_bus(s), open_bus(s)
    try:
        _exchange(a, b)
    finally:
        a.shutdown()
        b.shutdown()


def test_open_socketcand_pair_through_hub():
    with HubThread() as hub:
        s = parse_bus_string(f"socketcand://127.0.0.1:{hub.port}/vcan0")
        a, b = open_bus(s), open_bus(s)
        try:
            _exchange(a, b)  # b's recv waits out its join grace (the hub holds the frame, then delivers it)
        finally:
            a.shutdown()
            b.shutdown()


def test_frame_bits_and_bus_load():
    # classic CAN, 11-bit ID, 8 data bytes: 111 bits unstuffed, at most 24 stuff bits
    assert frame_bits(8) == 135
    assert frame_bits(0) == 55
    # two 8-byte TPDOs + one 1-byte SYNC per 10 ms at 1 Mbit/s
    load = bus_load({8: 200.0, 1: 100.0})
    assert load == pytest.approx((200 * 135 + 100 * 65) / 1e6)
