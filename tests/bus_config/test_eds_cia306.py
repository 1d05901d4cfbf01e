"""The EDS files (both nodes and the simulated I/O module) against CiA 306 basics, read by an independent INI
reader (configparser), not by
canopen's parser or the project's EdsInfo: required sections and keys, object lists consistent with
the object sections, valid ObjectType/DataType/AccessType/PDOMapping, numbers that parse, defaults and
limits inside the data type and inside each other; and lines every EDS reader can split (issue 12:
canopen-monitor splits every line on "=" and crashed on a description containing " = ")."""

from __future__ import annotations

import configparser
import re
import struct

import pytest

from telethermo.bus_config import path

ROLES = ("master", "slave", "io_module")
#: the node-ID each file's $NODEID values are checked with (io_module: the simulated I/O module, issue 24)
NODE_IDS = {"master": 1, "slave": 2, "io_module": 3}

FILE_INFO_KEYS = (
    "FileName",
    "FileVersion",
    "FileRevision",
    "EDSVersion",
    "Description",
    "CreationTime",
    "CreationDate",
    "CreatedBy",
    "ModificationTime",
    "ModificationDate",
    "ModifiedBy",
)
DEVICE_INFO_KEYS = (
    "VendorName",
    "VendorNumber",
    "ProductName",
    "ProductNumber",
    "RevisionNumber",
    "OrderCode",
    *(f"BaudRate_{r}" for r in (10, 20, 50, 125, 250, 500, 800, 1000)),
    "SimpleBootUpMaster",
    "SimpleBootUpSlave",
    "Granularity",
    "DynamicChannelsSupported",
    "GroupMessaging",
    "NrOfRXPDO",
    "NrOfTXPDO",
    "LSS_Supported",
)
ACCESS_TYPES = {"ro", "wo", "rw", "rwr", "rww", "const"}
# CiA 301 basic data types: (min, max) of the integers; None for REAL and strings
INT_RANGES = {
    0x0001: (0, 1),
    0x0002: (-(2**7), 2**7 - 1),
    0x0003: (-(2**15), 2**15 - 1),
    0x0004: (-(2**31), 2**31 - 1),
    0x0005: (0, 2**8 - 1),
    0x0006: (0, 2**16 - 1),
    0x0007: (0, 2**32 - 1),
    0x0015: (-(2**63), 2**63 - 1),
    0x001B: (0, 2**64 - 1),
}
REAL_TYPES = {0x0008: 3.4028234663852886e38, 0x0011: 1.7976931348623157e308}
STRING_TYPES = {0x0009, 0x000A, 0x000B, 0x000F}
OBJECT_TYPES = {0x7: "VAR", 0x8: "ARRAY", 0x9: "RECORD"}


def _read(role: str) -> tuple[str, configparser.ConfigParser]:
    text = path(f"{role}.eds").read_text(encoding="ascii")
    cp = configparser.ConfigParser(
        interpolation=None,
        strict=True,
        delimiters=("=",),
        comment_prefixes=(";",),
        inline_comment_prefixes=None,
    )
    cp.optionxform = str  # keys are case-sensitive in our checks
    cp.read_string(text)
    return text, cp


def _int(text: str, node_id: int = 1) -> int:
    text = text.strip()
    if text.upper().startswith("$NODEID"):
        rest = text[len("$NODEID") :].strip()
        return node_id + (int(rest.lstrip("+").strip(), 0) if rest else 0)
    return int(text, 0)


def _listed(cp, section: str) -> list[int]:
    n = int(cp[section]["SupportedObjects"], 0)
    keys = sorted(k for k in cp[section] if k != "SupportedObjects")
    assert keys == sorted(str(i) for i in range(1, n + 1)), f"[{section}] entries 1..{n}"
    return [int(cp[section][str(i)], 0) for i in range(1, n + 1)]


@pytest.mark.parametrize("role", ROLES)
def test_every_line_splits_into_one_key_and_one_value(role):
    text, _ = _read(role)
    for no, line in enumerate(text.splitlines(), 1):
        if not line or line.startswith("[") or line.startswith(";"):
            continue
        parts = line.split("=")  # what canopen-monitor does with every line
        assert len(parts) == 2 and parts[0] and parts[0] == parts[0].strip(), f"{role}.eds:{no}: {line!r}"
        assert ";" not in parts[1], f"{role}.eds:{no}: ';' starts a comment for some parsers: {line!r}"
        assert line.isascii()


@pytest.mark.parametrize("role", ROLES)
def test_file_and_device_info(role):
    _, cp = _read(role)
    for section, keys in (("FileInfo", FILE_INFO_KEYS), ("DeviceInfo", DEVICE_INFO_KEYS)):
        assert section in cp, f"[{section}] missing"
        missing = [k for k in keys if k not in cp[section]]
        assert not missing, f"[{section}] lacks {missing}"
    fi, di = cp["FileInfo"], cp["DeviceInfo"]
    assert fi["FileName"] == f"{role}.eds"
    assert 0 <= int(fi["FileVersion"], 0) <= 255 and 0 <= int(fi["FileRevision"], 0) <= 255
    assert re.fullmatch(r"\d+\.\d+", fi["EDSVersion"])
    for key in ("CreationDate", "ModificationDate"):
        assert re.fullmatch(r"(0[1-9]|1[0-2])-(0[1-9]|[12]\d|3[01])-\d{4}", fi[key]), (
            f"{key}={fi[key]} (mm-dd-yyyy)"
        )
    for key in ("CreationTime", "ModificationTime"):
        assert re.fullmatch(r"(0\d|1[0-2]):[0-5]\d(AM|PM)", fi[key]), f"{key}={fi[key]} (hh:mm(AM|PM))"
    for key in ("VendorNumber", "ProductNumber", "RevisionNumber"):
        assert 0 <= int(di[key], 0) <= 0xFFFFFFFF
    for key in [k for k in DEVICE_INFO_KEYS if k.startswith("BaudRate_")] + [
        "SimpleBootUpMaster",
        "SimpleBootUpSlave",
        "DynamicChannelsSupported",
        "GroupMessaging",
        "LSS_Supported",
    ]:
        assert di[key] in ("0", "1"), f"{key}={di[key]}"
    assert 0 <= int(di["Granularity"], 0) <= 64
    sections = {s.upper() for s in cp.sections()}
    n_rx = sum(f"{0x1400 + i:04X}" in sections for i in range(512))
    n_tx = sum(f"{0x1800 + i:04X}" in sections for i in range(512))
    assert (int(di["NrOfRXPDO"]), int(di["NrOfTXPDO"])) == (n_rx, n_tx)


@pytest.mark.parametrize("role", ROLES)
def test_object_lists_match_the_object_sections(role):
    _, cp = _read(role)
    mandatory = _listed(cp, "MandatoryObjects")
    optional = _listed(cp, "OptionalObjects")
    manufacturer = _listed(cp, "ManufacturerObjects")
    assert {0x1000, 0x1001, 0x1018} <= set(mandatory)
    assert all(0x1000 <= i <= 0x1FFF or 0x6000 <= i <= 0xFFFF for i in optional)
    assert all(0x2000 <= i <= 0x5FFF for i in manufacturer)
    listed = mandatory + optional + manufacturer
    assert len(listed) == len(set(listed)), "an object listed twice"
    objects = {int(s, 16) for s in cp.sections() if re.fullmatch(r"[0-9A-Fa-f]{4}", s)}
    assert objects == set(listed), (
        f"listed but no section: {set(listed) - objects}; section not listed: {objects - set(listed)}"
    )


def _check_var(role: str, section: str, sec) -> None:
    for key in ("ParameterName", "DataType", "AccessType"):
        assert key in sec, f"[{section}] lacks {key}"
    assert sec["ParameterName"].strip()
    dt = int(sec["DataType"], 0)
    assert dt in INT_RANGES or dt in REAL_TYPES or dt in STRING_TYPES, f"[{section}] DataType 0x{dt:04X}"
    assert sec["AccessType"].lower() in ACCESS_TYPES, f"[{section}] AccessType={sec['AccessType']}"
    assert sec.get("PDOMapping", "0") in ("0", "1")
    if sec.get("PDOMapping", "0") == "1":
        assert dt not in STRING_TYPES, f"[{section}] a string mapped into a PDO"
    values = {k: sec[k] for k in ("DefaultValue", "LowLimit", "HighLimit") if sec.get(k, "").strip()}
    if dt in STRING_TYPES:
        assert "LowLimit" not in values and "HighLimit" not in values
        return
    nums = {}
    for key, text in values.items():
        if dt in REAL_TYPES:
            x = float(text)
            assert abs(x) <= REAL_TYPES[dt], f"[{section}] {key}={text} outside the type"
            if dt == 0x0008:  # representable as REAL32 without overflow
                assert abs(struct.unpack("<f", struct.pack("<f", x))[0]) <= REAL_TYPES[dt]
        else:
            x = _int(text, NODE_IDS[role])
            lo, hi = INT_RANGES[dt]
            assert lo <= x <= hi, f"[{section}] {key}={text} outside 0x{dt:04X} [{lo}, {hi}]"
        nums[key] = x
    if "LowLimit" in nums and "HighLimit" in nums:
        assert nums["LowLimit"] <= nums["HighLimit"], f"[{section}] LowLimit > HighLimit"
    if "DefaultValue" in nums:
        assert (
            nums.get("LowLimit", nums["DefaultValue"])
            <= nums["DefaultValue"]
            <= nums.get("HighLimit", nums["DefaultValue"])
        ), f"[{section}] DefaultValue outside [LowLimit, HighLimit]"


@pytest.mark.parametrize("role", ROLES)
def test_objects_and_entries(role):
    _, cp = _read(role)
    sections = {s.upper(): s for s in cp.sections()}
    n_vars = 0
    for name in cp.sections():
        if not re.fullmatch(r"[0-9A-Fa-f]{4}", name):
            continue
        sec = cp[name]
        ot = int(sec.get("ObjectType", "0x7"), 0)
        assert ot in OBJECT_TYPES, f"[{name}] ObjectType 0x{ot:X}"
        if ot == 0x7:
            _check_var(role, name, sec)
            n_vars += 1
            continue
        assert "ParameterName" in sec and "SubNumber" in sec, (
            f"[{name}] {OBJECT_TYPES[ot]} needs ParameterName, SubNumber"
        )
        subs = sorted(
            int(s.upper().split("SUB")[1], 16) for s in sections if s.startswith(f"{name.upper()}SUB")
        )
        assert len(subs) == int(sec["SubNumber"], 0), f"[{name}] SubNumber vs sub-sections {subs}"
        assert subs[0] == 0
        sub0 = cp[sections[f"{name.upper()}SUB0"]]
        assert int(sub0["DataType"], 0) == 0x0005, f"[{name}sub0] must be UNSIGNED8"
        assert sub0["AccessType"].lower() in ("ro", "const", "rw")
        if (
            ot == 0x8 and name != "1003"
        ):  # ARRAY: sub 0 = the highest sub-index (0x1003: the number of errors)
            assert _int(sub0["DefaultValue"]) == max(subs), f"[{name}sub0] DefaultValue vs highest sub-index"
        for s in subs:
            sname = sections[f"{name.upper()}SUB{s:X}"]
            _check_var(role, sname, cp[sname])
            n_vars += 1
    assert n_vars > (50 if role == "io_module" else 100)


@pytest.mark.parametrize("role", ROLES)
def test_the_mandatory_objects_have_their_cia301_types(role):
    _, cp = _read(role)
    assert int(cp["1000"]["DataType"], 0) == 0x0007 and cp["1000"]["AccessType"].lower() in ("ro", "const")
    assert int(cp["1001"]["DataType"], 0) == 0x0005 and cp["1001"]["AccessType"].lower() == "ro"
    assert int(cp["1018"]["ObjectType"], 0) == 0x9
    assert int(cp["1018sub1"]["DataType"], 0) == 0x0007  # Vendor-ID UNSIGNED32
