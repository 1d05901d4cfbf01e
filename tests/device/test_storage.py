"""CiA 301 0x1010/0x1011 of the device layer (telethermo.device.storage) against canopen's SDO client on the
virtual bus, and the store file's checks: each fault is named with the file in one line."""

from __future__ import annotations

import json

import pytest
from canopen import SdoAbortedError

from telethermo.device.storage import (
    APPLICATION,
    COMMUNICATION,
    StoreError,
    StoreFile,
    StoreRestore,
    _crc,
    communication_image,
    install_communication,
)


def test_signatures_capability_and_a_failed_store(lab):
    dev = lab.device("master")
    node = lab.client("master")
    calls = []

    def save(group):
        calls.append(("save", group))
        if group == COMMUNICATION:
            raise OSError("disk full")

    StoreRestore(dev, save=save, restore=lambda group: calls.append(("load", group)))
    node.sdo.download(0x1010, APPLICATION, b"save")
    node.sdo.download(0x1011, 1, b"load")
    assert calls == [("save", APPLICATION), ("load", 1)]
    assert [node.sdo[0x1010][s].raw for s in (1, 2, 3)] == [1, 1, 1]
    assert node.sdo[0x1011][1].raw == 1
    with pytest.raises(SdoAbortedError) as exc:
        node.sdo.download(0x1010, 1, b"evas")  # the bytes reversed: not the signature
    assert exc.value.code == 0x08000020
    with pytest.raises(SdoAbortedError) as exc:
        node.sdo.download(0x1010, COMMUNICATION, b"save")
    assert exc.value.code == 0x06060000 and node.sdo[0x1010][2].raw == 1
    assert len(calls) == 3


def test_communication_values_become_the_power_on_values(lab):
    dev = lab.device("master")
    node = lab.client("master")
    node.sdo[0x1017].raw = 170
    image = communication_image(dev)
    assert image["0x1017:0"] == (170).to_bytes(2, "little").hex()
    assert not any(k.startswith(("0x1003:", "0x1005:", "0x1010:", "0x1011:")) for k in image)
    other = lab.device("master", node_id=5, start=False)
    assert install_communication(other, dict(image, **{"0x7777:0": "00"}), live=False) == [
        "0x7777:0: not a stored object of master.eds (or another size)"
    ]
    other.start()
    assert other.read(0x1017) == 100 and other.od_access.defaults[(0x1017, 0)] == (170).to_bytes(2, "little")


def _file(tmp_path, text: str | None = None) -> StoreFile:
    f = StoreFile(tmp_path / "node1.json", 1)
    f.write(
        communication={"0x1017:0": "9600"},
        application={"params": [["kp_A_per_C", 2.0]], "model": None},
        saved_unix_s=1.5,
    )
    if text is not None:
        f.path.write_text(text)
    return f


def test_the_store_file_round_trips_and_each_fault_is_named(tmp_path):
    f = _file(tmp_path)
    doc = f.read()
    assert doc["application"]["params"] == [["kp_A_per_C", 2.0]] and doc["saved_unix_s"] == 1.5
    good = f.path.read_text()

    def changed(**kw) -> str:
        return json.dumps({k: v for k, v in dict(json.loads(good), **kw).items() if v is not None})

    cases = {
        good[:40]: "not valid JSON",
        changed(format="telethermo-store 9"): "field 'format'",
        changed(application={"params": [["kp_A_per_C", 3.0]], "model": None}): "field 'crc32': checksum",
        changed(crc32=None): "field 'crc32': expected",
    }
    for text, words in cases.items():
        with pytest.raises(StoreError) as exc:
            _file(tmp_path, text).read()
        msg = str(exc.value)
        assert msg.startswith(str(f.path)) and words in msg and "\n" not in msg, msg
    f.path.write_text(good)
    with pytest.raises(StoreError, match="field 'node_id': expected 2"):
        StoreFile(f.path, 2).read()
    assert f.remove() and not f.remove()
    with pytest.raises(FileNotFoundError):
        f.read()


def test_a_store_file_with_a_field_of_the_wrong_type_is_refused_naming_it(tmp_path):
    """A file whose checksum is right but whose fields are not (written by hand, the CRC recomputed) is
    refused with one line, as a damaged one is; before, a malformed checksum ('0xzz') or a text
    saved_unix_s escaped as a bare ValueError past the node's fallback to its defaults."""
    f = _file(tmp_path)
    good = json.loads(f.path.read_text())

    def with_crc(**kw) -> str:
        body = {k: v for k, v in dict(good, **kw).items() if k != "crc32"}
        return json.dumps(dict(body, crc32=f"0x{_crc(body):08X}"))

    cases = {
        json.dumps(
            dict(good, crc32="0xzz")
        ): "field 'crc32': expected a hex checksum '0x........', got '0xzz'",
        with_crc(saved_unix_s="yesterday"): "field 'saved_unix_s': expected a number >= 0 s, got 'yesterday'",
        with_crc(node_id="1"): "field 'node_id': expected 1 (this node's ID), got '1'",
        with_crc(application=[1]): "field 'application': expected an object or null, got [1]",
        "[1, 2]": "top level: expected a JSON object {...}, got an array",
        '{"format": "telethermo-store 1",\n"node_id": 1 }}': "line 2 column 15: not valid JSON (Extra data)",
    }
    for text, message in cases.items():
        f.path.write_text(text)
        with pytest.raises(StoreError) as exc:
            f.read()
        assert str(exc.value) == f"{f.path}: {message}"
    f.path.write_bytes(b'{"format": "telethermo-store 1", "x": "\xff"}')
    with pytest.raises(StoreError, match=r": line 1: not UTF-8 text \(byte 0xFF\)$"):
        f.read()
