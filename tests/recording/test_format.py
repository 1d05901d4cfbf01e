"""The one recording writer: the offline runner's write_recording_csv goes through the nodes' journaled
CsvRecorder, and the file is the documented format, byte for byte."""

from __future__ import annotations

import math
import os
import stat

import numpy as np
import pytest

from telethermo.recording.format import (
    COLUMNS,
    Recording,
    header_comments,
    node_columns,
    read_recording_csv,
    write_recording_csv,
)
from telethermo.recording.journal import journal_path, recover_journal


def _rec() -> Recording:
    return Recording(
        meta={"scene": "s", "period_s": 0.01},
        columns={
            "t_s": np.array([0.0, 0.01]),
            "m_T_sensor_C": np.array([33.0, 33.125]),
            "m_contact": np.array([0.0, 1.0]),
            "m_Q_W": np.array([math.nan, -0.1]),
            "m_limits": ["", "ramp|guard"],
        },
    )


def test_the_offline_writer_writes_the_documented_format(tmp_path):
    p = write_recording_csv(tmp_path / "r.csv", _rec())
    assert p.read_bytes() == (
        b"# telethermo-recording 1\n"
        b'# meta {"period_s": 0.01, "scene": "s"}\n'
        b"t_s,m_T_sensor_C,m_contact,m_Q_W,m_limits\n"
        b"0,33,0,nan,\n"
        b"0.01,33.125,1,-0.1,ramp|guard\n"
    )
    assert not journal_path(p).exists()
    back = read_recording_csv(p)
    assert back.text("m_limits") == ["", "ramp|guard"] and back.col("m_T_sensor_C")[1] == 33.125


def test_a_killed_writers_journal_is_kept_beside_not_overwritten(tmp_path):
    target = tmp_path / "r.csv"
    journal_path(target).write_text("# telethermo-recording 1\n# meta {}\nt_s\n0.5\n0.6", encoding="utf-8")
    write_recording_csv(target, _rec())
    killed = [f for f in tmp_path.iterdir() if ".killed-" in f.name]
    assert len(killed) == 1 and killed[0].read_text(encoding="utf-8").splitlines()[2:] == ["t_s", "0.5"]
    assert read_recording_csv(target).meta == {"period_s": 0.01, "scene": "s"}


@pytest.mark.parametrize("umask", [0o022, 0o027])
def test_a_recovered_recording_gets_the_mode_of_a_new_file(tmp_path, umask):
    """Issue 25: the recovered recording of a killed node was mode 0600 (mkstemp's), where the recording a
    node closes normally is 0666 less the umask; so was the journal kept beside a new recording."""
    journal = journal_path(tmp_path / "slave.csv")
    journal.write_text("# telethermo-recording 1\n# meta {}\nt_s\n0.5\n0.6\n0.7", encoding="utf-8")
    old = os.umask(umask)
    try:
        recovered = recover_journal(tmp_path / "slave.csv")
        journal_path(tmp_path / "r.csv").write_text(
            "# telethermo-recording 1\n# meta {}\nt_s\n0.5\n0.6", encoding="utf-8"
        )
        written = write_recording_csv(tmp_path / "r.csv", _rec())
    finally:
        os.umask(old)
    assert read_recording_csv(recovered).col("t_s").tolist() == [0.5, 0.6]  # the torn 0.7 dropped
    killed = [f for f in tmp_path.iterdir() if ".killed-" in f.name]
    for f in (recovered, written, *killed):
        assert stat.S_IMODE(f.stat().st_mode) == 0o666 & ~umask, f.name


def test_a_node_recording_has_its_side_of_the_columns_and_the_sync_cycle():
    """Both node programs (and the nodes benchmark) take their columns from the format: each side's, in the
    documented order, after ``t_s`` and ``sync_cycle``; the two sides and the reference make up COLUMNS."""
    m, s = node_columns("m"), node_columns("s")
    assert m[:2] == s[:2] == ["t_s", "sync_cycle"]
    assert all(c.startswith("m_") for c in m[2:]) and all(c.startswith("s_") for c in s[2:])
    assert "m_true_finger_C" in m and "m_current_A" in m and "s_new_trips" in s
    ref = [c for c in COLUMNS if c.startswith("ref_")]
    assert sorted(["t_s", *m[2:], *s[2:], *ref]) == sorted(COLUMNS)


def test_a_nan_in_the_meta_is_written_and_read_back(tmp_path):
    """The offline writer keeps a NaN of the meta as the nodes' recordings do (JSON's NaN extension): the
    shipped render scene's meta carries one (the later phase's tau_s it does not use), and refusing it made
    write_session fail on that scene."""
    rec = _rec()
    rec = Recording(meta=dict(rec.meta, tau_s=math.nan), columns=rec.columns)
    back = read_recording_csv(write_recording_csv(tmp_path / "r.csv", rec))
    assert math.isnan(back.meta["tau_s"]) and back.meta["scene"] == "s"


def test_the_header_refuses_nan_in_the_meta_unless_asked():
    """header_comments alone refuses a NaN (strict JSON) unless asked; both writers ask."""
    with pytest.raises(ValueError):
        header_comments({"x": math.nan})
    magic, meta = header_comments({"b": math.nan, "a": 1}, allow_nan=True)
    assert magic == "telethermo-recording 1" and meta == 'meta {"a": 1, "b": NaN}'
