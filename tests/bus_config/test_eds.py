"""The EDS files: canopen parses them without a warning, the contract objects are there, names and
limits are usable, and the checked-in files are what bus_config/edsgen.py generates."""

from __future__ import annotations

import logging
import math
import struct
import warnings

import canopen
import pytest

from telethermo.bus_config import edsgen, path
from telethermo.device.eds_info import EdsError, EdsInfo

ROLES = ("master", "slave")


@pytest.mark.parametrize("role", ROLES)
def test_canopen_parses_without_warnings(role, caplog):
    caplog.set_level(logging.DEBUG, logger="canopen")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        od = canopen.import_od(str(path(f"{role}.eds")), edsgen.NODE_IDS[role])
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING], caplog.text
    for index in (
        0x1000,
        0x1001,
        0x1003,
        0x1005,
        0x1006,
        0x1014,
        0x1016,
        0x1017,
        0x1018,
        0x1019,
        0x1400,
        0x1600,
        0x1800,
        0x1A00,
        0x1801,
        0x1A01,
        0x1802,
        0x1A02,
        0x1803,
        0x1A03,
    ):
        assert index in od, hex(index)


@pytest.mark.parametrize("role", ROLES)
def test_checked_in_files_match_generator(role):
    assert path(f"{role}.eds").read_text(encoding="ascii") == edsgen.render(role)


def test_pdo1_contract_between_the_two_files():
    """Each node's TPDO1 is the other's RPDO1: same COB-ID, two REAL32 in the same order."""
    m = canopen.import_od(str(path("master.eds")), 1)
    s = canopen.import_od(str(path("slave.eds")), 2)
    assert m[0x1800][1].default == 0x181 and s[0x1400][1].default == 0x181
    assert s[0x1800][1].default == 0x182 and m[0x1400][1].default == 0x182
    for od in (m, s):
        assert od[0x1800][2].default == 1 and od[0x1400][2].default == 1  # synchronous, every SYNC
        assert od[0x1005].default & 0x7FF == 0x80
        assert od[0x1017].default == 100
        tx = [od[0x1A00][i].default for i in (1, 2)]
        rx = [od[0x1600][i].default for i in (1, 2)]
        assert [e & 0xFF for e in tx + rx] == [32] * 4
        for e in tx + rx:
            assert od[e >> 16].data_type == canopen.objectdictionary.REAL32
    assert m[0x1005].default & (1 << 30) and not s[0x1005].default & (1 << 30)  # master produces SYNC
    assert (m[0x1016][1].default >> 16) == 2 and (s[0x1016][1].default >> 16) == 1


@pytest.mark.parametrize("role", ROLES)
def test_every_writable_manufacturer_object_has_a_range_and_reals_a_unit(role):
    info = EdsInfo(path(f"{role}.eds"))
    writable = [v for (i, _), v in info.vars.items() if i >= 0x2000 and v.writable]
    assert len(writable) > 20
    # a one-value range: a slave-side parameter the master shows but keeps at that value (its guard off)
    fixed = {"master": {"osc_guard_C"}, "slave": set()}[role]
    for v in writable:
        assert v.low is not None and v.high is not None, v.key
        assert v.low < v.high or (v.key in fixed and v.low == v.high), v.key
    dimensionless = (
        "theta",
        "flux_coeff",
        "material_beta",
        "pad_beta",
        "identified_beta",
        "identified_se_ln_b",
        "identified_posterior",
        "peer_identified_beta",
        "identified_early_posterior",
    )
    for (index, _), v in info.vars.items():
        if index < 0x2000:
            continue
        implied = next((t for suffix, t in edsgen.UNIT_TEXT.items() if v.name.endswith(suffix)), "")
        assert v.unit == implied, v.key  # the name suffix and the Unit= key agree
        if v.data_type == 0x0008:
            assert v.unit or v.name.startswith(dimensionless), v.key


def test_real32_limits_are_recovered_although_canopen_drops_them():
    od = canopen.import_od(str(path("master.eds")), 1)
    assert od["T_max_C"].max is None  # canopen 2.4 drops decimal limits...
    info = EdsInfo(path("master.eds"))
    assert (info.get("T_min_C").low, info.get("T_max_C").high) == (15.0, 43.0)  # ...we do not
    assert info.get("kp_A_per_C").unit == "A/degC"
    assert info.get("mode").high == 3 and info.get("mode").low == 0


def test_names_resolve_like_the_cli_uses_them():
    info = EdsInfo(path("slave.eds"))
    assert (info.get("theta3").index, info.get("theta3").subindex) == (0x2310, 3)
    assert info.get("Identity object.Product code").key == "Identity object.Product code"
    assert info.get("0x1018sub2") is info.get("Identity object.Product code")
    assert info.get("0x2200:0").name == "kp_A_per_C"
    with pytest.raises(KeyError, match="did you mean kp_A_per_C"):
        info.get("kp")


def test_safety_defaults_match_design():
    """DESIGN.md §6: clamp [15, 43] °C, ramp ~5 °C/s, heat-sink trip 55 °C, neutral ~32 °C;
    the ranges only allow narrowing."""
    info = EdsInfo(path("master.eds"))
    assert float(info.get("T_min_C").default) == 15.0 and float(info.get("T_max_C").default) == 43.0
    assert info.get("T_max_C").high == 43.0 and info.get("T_min_C").low == 15.0
    assert info.get("sink_trip_C").high == 55.0 and info.get("ramp_limit_C_per_s").high == 5.0
    assert float(info.get("neutral_C").default) == 32.0


def test_bad_eds_is_refused_with_file_section_and_key(tmp_path):
    bad = tmp_path / "bad.eds"
    bad.write_text(
        path("master.eds").read_text(encoding="ascii").replace("LowLimit=15.0", "LowLimit=fifteen", 1),
        encoding="ascii",
    )
    with pytest.raises(EdsError, match=r"bad.eds: \[2400\] LowLimit: expected a number"):
        EdsInfo(bad)


def test_real32_limit_check_codes():
    info = EdsInfo(path("master.eds"))
    v = info.get("T_max_C")
    assert info.check(v, 40.0) is None
    assert info.check(v, 43.5) == 0x06090031
    assert info.check(v, 14.0) == 0x06090032
    assert info.check(v, math.nan) == 0x06090030
    # a REAL32 just above the limit after rounding is still refused
    above = struct.unpack("<f", struct.pack("<f", 43.0001))[0]
    assert info.check(v, above) == 0x06090031


@pytest.mark.parametrize("role", ROLES)
def test_power_on_values_match_the_control_cores_defaults(role):
    """The EDS safety defaults a fresh node boots with are the control core's own defaults (gains
    are placeholders the node program overwrites before start())."""
    from telethermo.control.estimators import Estimator
    from telethermo.control.safety import SafetyState
    from telethermo.control.types import Mode

    from telethermo.control.safety import SafetyLimits, probe_limits

    info = EdsInfo(path(f"{role}.eds"))
    sp = SafetyLimits() if role == "master" else probe_limits()  # skin on the master, the probe's hardware
    for name, field in (("T_min_C", "T_min_C"), ("T_max_C", "T_max_C"), ("hot_threshold_C", "hot_C")):
        assert float(info.get(name).default) == getattr(sp, field)
    assert (info.get("T_min_C").low, info.get("T_max_C").high) == sp.widest_C
    assert float(info.get("hot_time_limit_s").default) == sp.hot_time_limit_s
    assert float(info.get("sink_trip_C").default) == sp.sink_trip_C
    assert float(info.get("current_limit_A").default) == pytest.approx(sp.current_fraction * sp.I_max_A)
    assert info.get("mode").high == max(Mode) and info.get("mode").low == min(Mode)
    assert info.get("estimator").high == len(Estimator) - 1
    assert "3 current cut" in info.get("safety_state").description and max(SafetyState) == 3


def test_docs_table_is_the_generated_one():
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[2] / "docs" / "canopen.md").read_text(encoding="utf-8")
    assert edsgen.markdown_table("master") in doc  # regenerate: python -m telethermo.bus_config.edsgen
