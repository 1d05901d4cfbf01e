"""The streaming CSV recorder: exact values back, atomic appearance."""
from __future__ import annotations

import csv
import math

import pytest

from nodes.recorder import CsvRecorder


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
    assert path.read_text().splitlines()[1:] == [f"{0.1!r},{1 / 3!r},1,0,-inf,x|y",
                                                 "1e-300,30.000000000000004,2,0,nan,"]
