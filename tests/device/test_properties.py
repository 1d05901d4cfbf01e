"""Property: whatever REAL32 or integer value a client writes to a ranged object, it is stored iff it
lies in the EDS range, and otherwise refused with the matching code and the old value kept."""

from __future__ import annotations

import contextlib
import math
import uuid

import canopen
import pytest
from canopen import SdoAbortedError
from hypothesis import given, settings, strategies as st

from telethermo.bus_config import path
from telethermo.device import Device
from telethermo.device.eds_info import EdsInfo

INFO = EdsInfo(path("master.eds"))
REALS = sorted(
    v.key
    for (i, _), v in INFO.vars.items()
    if i >= 0x2000 and v.writable and v.data_type == 0x0008 and v.low is not None
)
INTS = sorted(
    v.key
    for (i, _), v in INFO.vars.items()
    if i >= 0x2000 and v.writable and v.data_type in (5, 6, 7) and v.low is not None
)


@pytest.fixture(scope="module")
def node():
    """One device (node 1) and canopen's SDO client, shared by all examples of this module."""
    channel = f"tt-prop-{uuid.uuid4().hex[:8]}"
    with contextlib.ExitStack() as stack:

        def network() -> canopen.Network:
            net = canopen.Network()
            net.NOTIFIER_CYCLE = 0.05
            net.connect(interface="virtual", channel=channel)
            stack.callback(net.disconnect)
            return net

        dev = Device(network(), 1, path("master.eds"))
        stack.callback(dev.close)
        dev.start()
        yield network().add_node(1, str(path("master.eds")))


def expected_code(key: str, value: float) -> int | None:
    v = INFO.get(key)
    if isinstance(value, float) and math.isnan(value):
        return 0x06090030
    if value > v.high:
        return 0x06090031
    if value < v.low:
        return 0x06090032
    return None


def check_write(node, key, value) -> None:
    before = node.sdo[key].raw
    code = expected_code(key, value)
    try:
        node.sdo[key].raw = value
        got = None
    except SdoAbortedError as exc:
        got = exc.code
    assert got == code, (key, value)
    after = node.sdo[key].raw
    if code is None:
        assert after == value
    else:
        assert after == before or (math.isnan(after) and math.isnan(before))


@settings(max_examples=60, deadline=None)
@given(key=st.sampled_from(REALS), value=st.floats(width=32))
def test_real32_writes_respect_the_eds_range(node, key, value):
    check_write(node, key, value)


@settings(max_examples=40, deadline=None)
@given(key=st.sampled_from(INTS), value=st.integers(0, 255))
def test_integer_writes_respect_the_eds_range(node, key, value):
    check_write(node, key, value)
