"""Fast subset of the fuzz cases (tests/stress/cases/fuzz.py): hypothesis against a real Device on a
python-can
virtual bus, against sim.load_scene and against telethermo.ident.load_model.

The five findings the fuzz made (``tests.stress.cases.fuzz.KNOWN_FINDINGS``: 29-bit frames reaching 11-bit
services, a stray SDO segment raising instead of aborting, huge integers and absurd current ranges in the
scene and model-file loaders) are fixed; each keeps a regression test below.
"""

import json
import time

import can
import pytest

from tests.stress.cases import fuzz as s
from tests.stress.cases import fuzz_frames as fr

pytestmark = pytest.mark.stress


def _sdo_reply(raw, timeout_s: float = 2.0):
    """The device's next SDO response frame (0x580 + id) on ``raw``, or None after ``timeout_s``."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        m = raw.recv(0.2)
        if m is not None and m.arbitration_id == 0x580 + fr.MASTER_ID:
            return m
    return None


def test_device_frames_never_crash_and_are_counted():
    r = fr.case_fuzz_frames(max_examples=60)
    f = r["figures"]
    assert f["examples_miscounted_unexplained"] == 0, f["mismatch_examples"]
    assert f["examples_escaped_unexplained"] == 0, f["escapes"]
    assert f["callback_errors"] == 0
    assert f["sdo_answers_after"] and f["heartbeat_after"]
    assert not r["failures"], r["failures"]


def test_29bit_frame_is_not_an_nmt_command():
    with fr.device_under_fuzz() as (dev, raw, counter, client, log):
        raw.send(can.Message(arbitration_id=0x000, is_extended_id=True, data=bytes([0x02, fr.MASTER_ID])))
        assert counter.wait(1)
        assert dev.state == 5  # still OPERATIONAL


def test_sdo_segment_request_without_transfer_is_aborted():
    with fr.device_under_fuzz() as (dev, raw, counter, client, log):
        raw.send(
            can.Message(
                arbitration_id=0x600 + fr.MASTER_ID, is_extended_id=False, data=bytes([0x60] + [0] * 7)
            )
        )
        assert counter.wait(1)
        reply = _sdo_reply(raw)
        assert not log.records, log.records
        assert reply is not None and reply.data[0] == 0x80  # an SDO abort


def _only_known(r, kinds):
    f = r["figures"]
    assert f["violations_unexplained"] == 0, f.get("first_unexplained") or f["first_violations"]
    assert f["violations"] == sum(f[f"violations_{k}_finding"] for k in kinds)


def test_scene_loader_only_scene_or_scene_error():
    r = s.case_fuzz_scene_loader(max_examples=30)
    _only_known(r, ())
    assert r["figures"]["scene_errors"] > 0


def test_model_loader_only_model_or_model_file_error():
    r = s.case_fuzz_model_loader(max_examples=30)
    _only_known(r, ())
    assert r["figures"]["refused"] > 0


def test_scene_huge_integer_is_a_scene_error(tmp_path):
    from telethermo import sim

    p = tmp_path / "huge.toml"
    text = (sim.scene.SCENES_DIR / "finger_on_display.toml").read_text(encoding="utf-8")
    p.write_text(text.replace("period_s = 0.01", "period_s = 1" + "0" * 400), encoding="utf-8")
    with pytest.raises(sim.SceneError, match="period_s"):
        sim.load_scene(p)


def test_model_huge_integer_is_a_model_file_error(tmp_path):
    from telethermo.ident import ModelFileError, load_model

    doc = s.base_model_doc()
    doc["temperature"]["period_s"] = 10**400
    p = tmp_path / "huge.json"
    p.write_text(json.dumps(doc), encoding="utf-8")
    with pytest.raises(ModelFileError, match="period_s"):
        load_model(p)


def test_model_huge_current_range_is_a_model_file_error(tmp_path):
    from telethermo.ident import ModelFileError, load_model

    doc = s.base_model_doc()
    doc["temperature"]["current_range_A"] = [-1e308, 1.0]
    p = tmp_path / "range.json"
    p.write_text(json.dumps(doc), encoding="utf-8")
    with pytest.raises(ModelFileError, match="current_range_A"):
        load_model(p)


def test_sdo_block_download_request_to_a_missing_object_is_aborted_without_an_error_log():
    """A block download (ccs 6) initiate naming an object the dictionary lacks (0x2200 sub 1; 0x2200 is a
    VAR):
    CiA 301 abort 0x06090011 (sub-index does not exist) for the named object at once, and no ERROR record."""
    with fr.device_under_fuzz() as (dev, raw, counter, client, log):
        raw.send(
            can.Message(
                arbitration_id=0x600 + fr.MASTER_ID,
                is_extended_id=False,
                data=bytes([0xC2, 0x00, 0x22, 0x01, 0, 0, 0, 0]),
            )
        )
        assert counter.wait(1)
        reply = _sdo_reply(raw)
        assert not log.records, log.records
        assert reply is not None and reply.data[0] == 0x80
        assert int.from_bytes(reply.data[1:3], "little") == 0x2200 and reply.data[3] == 1
        assert int.from_bytes(reply.data[4:8], "little") == 0x06090011
