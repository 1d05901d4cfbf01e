"""The streaming CSV recorder: exact values back, atomic appearance."""

from __future__ import annotations

import csv
import math

import numpy as np

import pytest

from telethermo.nodes.launch import wait_for
from telethermo.recording.journal import CsvRecorder

pytestmark = pytest.mark.slow  # starts processes


def test_rows_round_trip_exactly_and_appear_only_on_close(tmp_path):
    path = tmp_path / "rec" / "master.csv"
    rec = CsvRecorder(path, ["k", "t_s", "T_C", "contact"], flush_every=2)
    values = [(k, k * 0.01, 30.0 + 1 / 3 * k, k % 2 == 0) for k in range(5)]
    for v in values:
        rec.write(dict(zip(rec.columns, v)))
    rec.write([5, 0.05, math.nan, False])
    assert not path.exists()
    rec.close()
    rows = list(csv.DictReader(path.open()))
    assert [float(r["T_C"]) for r in rows[:5]] == [v[2] for v in values]
    assert math.isnan(float(rows[5]["T_C"])) and rows[0]["contact"] == "1"
    assert list(tmp_path.joinpath("rec").iterdir()) == [path]


def test_wrong_row_length_names_the_file(tmp_path):
    rec = CsvRecorder(tmp_path / "x.csv", ["a", "b"])
    with pytest.raises(ValueError, match="x.csv: row has 1 values, expected 2"):
        rec.write([1])
    rec.abort()
    assert list(tmp_path.iterdir()) == []


def test_final_comments_replace_the_header_on_close(tmp_path):
    path = tmp_path / "m.csv"
    rec = CsvRecorder(path, ["a"], comments=["magic", "meta {}"])
    rec.write([1.5])
    rec.set_final_comments(["magic", 'meta {"render": 1}'])
    with pytest.raises(ValueError, match="expected 2"):
        rec.set_final_comments(["only one"])
    rec.close()
    assert path.read_text() == '# magic\n# meta {"render": 1}\na\n1.5\n'


def test_values_are_written_in_their_shortest_round_trip_form(tmp_path):
    import numpy as np

    path = tmp_path / "v.csv"
    rec = CsvRecorder(path, ["a", "b", "c", "d", "e", "f"])
    rec.write([0.1, np.float64(1 / 3), True, False, -math.inf, "x|y"])
    rec.write([1e-300, 30.000000000000004, 2, 0, math.nan, ""])
    rec.close()
    assert path.read_text().splitlines()[1:] == [
        f"{0.1!r},{1 / 3!r},1,0,-inf,x|y",
        "1e-300,30.000000000000004,2,0,nan,",
    ]


# ------------------------------------------------------------------ the journal (nothing lost on SIGKILL)
_CHILD = """
import sys, time
from telethermo.recording.journal import CsvRecorder
rec = CsvRecorder(sys.argv[1], ["t_s", "sync_cycle", "x"], flush_every=10**9, sync_interval_s=0.05,
                  comments=["telethermo-recording 1", 'meta {"role": "slave"}'])
for k in range(int(sys.argv[2])):
    rec.write([k * 0.01, k, k / 3])
while rec.syncs < 2:          # the flusher has run after the last row: it is on disk
    time.sleep(0.01)
# a row torn by the kill (no line end), as a kill in the middle of a write leaves
rec._fh.write("99.0,9")
rec._fh.flush()
print("ready", flush=True)
time.sleep(600)  # on purpose: the parent kills this process while it sleeps
"""


def _killed_writer(tmp_path, rows: int):
    """A process writing ``rows`` rows with no row-count flush (only the journal's timer), killed with
    SIGKILL."""
    import signal
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    path = tmp_path / "slave.csv"
    proc = subprocess.Popen(
        [sys.executable, "-c", _CHILD, str(path), str(rows)], stdout=subprocess.PIPE, text=True, cwd=root
    )
    try:
        assert proc.stdout.readline().strip() == "ready"
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    return path


def test_a_killed_writers_journal_is_recovered_with_every_complete_row(tmp_path):
    from telethermo.recording.journal import journal_path, recover_journal
    from telethermo.recording.format import read_recording_csv

    path = _killed_writer(tmp_path, 123)
    assert not path.exists() and journal_path(path).exists()
    assert recover_journal(path) == path
    assert not journal_path(path).exists()
    rec = read_recording_csv(path)
    np.testing.assert_array_equal(rec.col("sync_cycle"), np.arange(123))  # all rows, the torn one dropped
    np.testing.assert_array_equal(rec.col("x"), np.arange(123) / 3)
    assert rec.meta["role"] == "slave"
    assert rec.meta["recovered"] == {"journal": "slave.csv.journal", "rows": 123, "dropped_tail_bytes": 6}
    with pytest.raises(OSError, match="no journal to recover"):
        recover_journal(path)


def test_the_next_start_recovers_the_journal_beside_the_new_recording(tmp_path):
    from telethermo.recording.journal import journal_path
    from telethermo.recording.format import read_recording_csv

    path = _killed_writer(tmp_path, 40)
    rec = CsvRecorder(path, ["t_s", "sync_cycle", "x"], comments=["telethermo-recording 1", "meta {}"])
    assert rec.recovered is not None and rec.recovered.name.startswith("slave.killed-")
    assert rec.recovered.suffix == ".csv"
    assert len(read_recording_csv(rec.recovered)) == 40
    rec.write([0.0, 0, 1.0])
    rec.close()
    assert len(read_recording_csv(path)) == 1 and not journal_path(path).exists()


def test_a_journal_in_use_is_not_recovered_and_rows_reach_it_without_close(tmp_path):
    from telethermo.recording.journal import RecorderError, journal_path, recover_journal

    path = tmp_path / "m.csv"
    rec = CsvRecorder(path, ["a"], flush_every=10**9, sync_interval_s=0.02)
    rec.write([1.5])
    rec.write([2.5])
    # the timer, not a row count nor close, pushes them out (polled with a deadline: no hang if it never runs)
    n = rec.syncs
    assert wait_for(lambda: rec.syncs >= n + 2, 30, poll_s=0.01), "the recorder's sync timer did not run"
    assert journal_path(path).read_text() == "a\n1.5\n2.5\n"
    with pytest.raises(RecorderError, match="in use by a running node"):
        recover_journal(path)
    with pytest.raises(RecorderError, match="in use by a running node"):
        CsvRecorder(path, ["a"])  # a second node on the same file: refused, the first one untouched
    rec.close()
    assert path.read_text() == "a\n1.5\n2.5\n"


def test_recordings_merge_on_the_sync_cycle_after_losses_and_fallback_cycles(tmp_path):
    from telethermo.recording.merge import merge_recordings
    from telethermo.recording.format import MAGIC

    head = [MAGIC[2:], 'meta {"period_s": 0.01}']
    m = CsvRecorder(tmp_path / "m.csv", ["t_s", "sync_cycle", "m_T_sensor_C"], comments=head)
    s = CsvRecorder(tmp_path / "s.csv", ["t_s", "sync_cycle", "s_T_sensor_C"], comments=head)
    for k in range(10):
        m.write([k * 0.01, k, 30 + k])
    # the slave missed SYNC 3 and 4 (killed? not OPERATIONAL), ran two local fallback cycles, then SYNC 5..8
    for t, c in [
        (0.0, 0),
        (0.01, 1),
        (0.02, 2),
        (0.03, -1),
        (0.04, -1),
        (0.05, 5),
        (0.06, 6),
        (0.07, 7),
        (0.08, 8),
    ]:
        s.write([t, c, 40 + c])
    m.close()
    s.close()
    rec = merge_recordings(tmp_path / "m.csv", tmp_path / "s.csv")
    np.testing.assert_array_equal(rec.col("sync_cycle"), [0, 1, 2, 5, 6, 7, 8])
    np.testing.assert_array_equal(rec.col("t_s"), np.array([0, 1, 2, 5, 6, 7, 8]) * 0.01)  # the master's axis
    np.testing.assert_array_equal(
        rec.col("s_T_sensor_C") - rec.col("m_T_sensor_C"), 10.0
    )  # same SYNC each row
