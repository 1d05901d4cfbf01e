"""SDO server of the device against canopen's SDO client: by name and index, range aborts with the
exact CiA 301 codes, the value left unchanged, read-only and unknown objects refused."""

from __future__ import annotations

import math

import pytest
from canopen import SdoAbortedError

from telethermo.device import OdWriteError


def abort_code(fn) -> int:
    with pytest.raises(SdoAbortedError) as exc:
        fn()
    return exc.value.code


def test_read_and_write_by_name_and_by_index(lab):
    dev = lab.device("master")
    node = lab.client("master")
    assert node.sdo["kp_A_per_C"].raw == pytest.approx(0.5)
    node.sdo["kp_A_per_C"].raw = 2.25
    assert dev.read("kp_A_per_C") == 2.25
    assert node.sdo[0x2200].raw == 2.25
    node.sdo[0x2500].raw = 1  # mode by index
    assert dev.read("mode") == 1 and node.sdo["mode"].raw == 1
    node.sdo["theta"][7].raw = -0.125  # an ARRAY entry
    assert dev.read("theta7") == -0.125
    assert node.sdo["Identity object"]["Product code"].raw == 1
    assert node.sdo[0x1008].raw == "telethermo master"  # segmented upload


@pytest.mark.parametrize(
    "name, value, code",
    [
        ("T_max_C", 60.5, 0x06090031),  # REAL32 above HighLimit (a limit canopen itself drops): the
        ("T_max_C", -0.5, 0x06090032),  # probe's [0, 60] °C on the slave; below LowLimit
        ("T_min_C", math.nan, 0x06090030),  # NaN: no place in any range
        ("kp_A_per_C", 20.5, 0x06090031),
        ("ramp_limit_C_per_s", 0.0, 0x06090032),
        ("mode", 4, 0x06090031),  # UNSIGNED8 with range 0..3
        ("peer_pdo_miss_limit", 0, 0x06090032),
        ("Synchronous counter overflow value", 1, 0x06090030),  # 1 is not a valid overflow
        ("Synchronous counter overflow value", 241, 0x06090031),
    ],
)
def test_out_of_range_write_is_aborted_with_the_exact_code_and_leaves_the_value(lab, name, value, code):
    dev = lab.device("slave")
    node = lab.client("slave")
    before = node.sdo[name].raw

    def write():
        node.sdo[name].raw = value

    assert abort_code(write) == code
    assert node.sdo[name].raw == before
    assert dev.read(name) == before


@pytest.mark.parametrize("value, code", [(43.5, 0x06090031), (14.0, 0x06090032)])
def test_the_masters_skin_clamps_refuse_a_wider_range(lab, value, code):
    """The master guards skin: T_max_C beyond [15, 43] °C is refused (the slave's probe allows [0, 60])."""
    lab.device("master")
    node = lab.client("master")
    before = node.sdo["T_max_C"].raw

    def write():
        node.sdo["T_max_C"].raw = value

    assert abort_code(write) == code and node.sdo["T_max_C"].raw == before


def test_boundaries_are_accepted(lab):
    lab.device("master")
    node = lab.client("master")
    for name, value in (("T_max_C", 43.0), ("T_max_C", 15.0), ("mode", 3), ("mode", 0)):
        node.sdo[name].raw = value
        assert node.sdo[name].raw == value


def test_read_only_unknown_and_wrong_length_are_refused(lab):
    dev = lab.device("master")
    node = lab.client("master")

    def write_ro():
        node.sdo["T_sensor_C"].raw = 30.0

    assert abort_code(write_ro) == 0x06010002
    assert abort_code(lambda: node.sdo.upload(0x2FFF, 0)) == 0x06020000
    assert abort_code(lambda: node.sdo.download(0x2200, 0, b"\x00\x00")) == 0x06070010  # 2 bytes to a REAL32
    assert dev.read("kp_A_per_C") == pytest.approx(0.5)


def test_local_writes_are_range_checked_too(lab):
    dev = lab.device("master")
    with pytest.raises(OdWriteError) as exc:
        dev.write("T_max_C", 50.0)
    assert exc.value.code == 0x06090031 and dev.read("T_max_C") == 43.0
    with pytest.raises(OdWriteError) as exc:
        dev.write("Synchronous counter overflow value", 1)  # communication objects: the SDO rules
    assert exc.value.code == 0x06090030 and dev.read("Synchronous counter overflow value") == 240
    dev.write("T_sensor_C", math.nan)  # measurements have no range: NaN must reach the envelope
    assert math.isnan(dev.read("T_sensor_C"))


def test_write_listener_sees_accepted_writes_only(lab):
    dev = lab.device("master")
    seen = []
    dev.add_write_listener(lambda ev: seen.append((ev.index, ev.subindex, ev.value)))
    node = lab.client("master")
    node.sdo["ki_A_per_C_s"].raw = 1.5
    with pytest.raises(SdoAbortedError):
        node.sdo["ki_A_per_C_s"].raw = 99.0
    assert seen == [(0x2201, 0, 1.5)]


def test_write_validator_refuses_with_its_abort_code_and_leaves_the_value(lab):
    """A pre-write validator (e.g. a mode the device cannot run now) answers the SDO download with its
    abort code before the value is stored: canopen's client sees the abort, the value is unchanged,
    no write listener fires; an accepted value goes through as before."""
    dev = lab.device("slave")
    calls, seen = [], []
    dev.add_write_validator("mode", lambda v: (calls.append(v), 0x08000022 if v == 2 else None)[1])
    dev.add_write_listener(lambda ev: seen.append((ev.index, ev.value)))
    node = lab.client("slave")
    node.sdo["mode"].raw = 1
    before = node.sdo["mode"].raw

    def write_render():
        node.sdo["mode"].raw = 2

    assert abort_code(write_render) == 0x08000022
    assert node.sdo["mode"].raw == before == 1 and dev.read("mode") == 1
    node.sdo["mode"].raw = 3
    assert dev.read("mode") == 3
    assert calls == [1, 2, 3]  # the decoded value, once per download
    assert seen == [(0x2500, 1), (0x2500, 3)]  # the refused write reached no listener
    # the EDS range check comes first: the validator never sees an out-of-range value
    assert abort_code(lambda: setattr(node.sdo["mode"], "raw", 9)) == 0x06090031
    assert calls == [1, 2, 3]


def test_a_failing_validator_refuses_with_a_general_error_and_is_counted(lab):
    dev = lab.device("master")

    def broken(value):
        raise RuntimeError("bug")

    dev.add_write_validator("kp_A_per_C", broken)
    node = lab.client("master")
    before = dev.read("kp_A_per_C")
    assert abort_code(lambda: setattr(node.sdo["kp_A_per_C"], "raw", 1.0)) == 0x08000000
    assert dev.read("kp_A_per_C") == before
    assert node.sdo["callback_errors"].raw == 1
    node.sdo["ki_A_per_C_s"].raw = 0.25  # other objects are untouched by it
    assert dev.read("ki_A_per_C_s") == 0.25


def test_a_boolean_takes_0_or_1_only(lab):
    """Issue 12 FAIL 4: BOOLEAN 0x230C accepted 2 and read back 2. Raw downloads (canopen's client would
    encode any true value as 1): 2 is out of range (0x06090030), two bytes are the wrong length
    (0x06070010); the value stays."""
    dev = lab.device("master")
    node = lab.client("master")
    node.sdo.download(0x230C, 0, b"\x01")
    assert node.sdo.upload(0x230C, 0) == b"\x01" and dev.read("flux_with_current") is True
    assert abort_code(lambda: node.sdo.download(0x230C, 0, b"\x02")) == 0x06090030
    assert abort_code(lambda: node.sdo.download(0x230C, 0, b"\xff")) == 0x06090030
    assert abort_code(lambda: node.sdo.download(0x230C, 0, b"\x00\x00")) == 0x06070010
    assert node.sdo.upload(0x230C, 0) == b"\x01"
    node.sdo.download(0x230C, 0, b"\x00")
    assert node.sdo.upload(0x230C, 0) == b"\x00"


def test_cob_id_sync_refuses_the_29_bit_frame_bit(lab):
    """Issue 12 FAIL 5: 0x1005 bit 29 (29-bit SYNC) was accepted while the node kept its 11-bit SYNC.
    Refused with 0x06090030 as CANopenNode does; the value stays and SYNC on 0x80 still works."""
    dev = lab.device("slave")
    node = lab.client("slave")
    ticks = []
    dev.add_sync_handler(lambda t: ticks.append(t.counter))
    assert abort_code(lambda: setattr(node.sdo["COB-ID SYNC"], "raw", 0x20000080)) == 0x06090030
    assert abort_code(lambda: setattr(node.sdo["COB-ID SYNC"], "raw", 0x200000A0)) == 0x06090030
    assert node.sdo["COB-ID SYNC"].raw == 0x80 and dev.sync_cob_id == 0x80
    node.network.sync.transmit(7)  # canopen's SYNC producer, 11-bit 0x80
    node.sdo["COB-ID SYNC"].raw  # SDO round trip: the SYNC before it was handled
    assert ticks == [7]
