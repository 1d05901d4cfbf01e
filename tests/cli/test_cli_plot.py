"""``telethermo plot FILE``: the picture of a real offline session's recording.csv and of the real
``--record`` CSVs of the two node processes (nodes.launch.NodePair, 150 lockstep cycles on our hub);
damaged files are one line naming the file and the line (exit 2)."""

from __future__ import annotations

import struct
import sys
from pathlib import Path

import numpy as np
import pytest

from telethermo.cli.main import EXIT_OK, EXIT_USAGE
from telethermo.recording.format import read_recording_csv

pytestmark = pytest.mark.slow  # starts processes

SCENE = Path(__file__).resolve().parents[2] / "sim" / "scenes" / "probe_touches_al_steel_wood.toml"
CYCLES = 150


def png_size(path: Path) -> tuple[int, int]:
    """(width, height) in pixels from the PNG's IHDR chunk."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR", f"{path} is not a PNG"
    return struct.unpack(">II", data[16:24])


@pytest.fixture(scope="module")
def offline_csv(tmp_path_factory) -> Path:
    from telethermo.offline import run_offline_session, write_session

    out = tmp_path_factory.mktemp("offline")
    write_session(out, run_offline_session("probe_touches_al_steel_wood", duration_s=3.0), png=False)
    return out / "recording.csv"


@pytest.fixture(scope="module")
def node_csvs(tmp_path_factory) -> dict[str, Path]:
    from telethermo.nodes.launch import NodePair, PairConfig

    out = tmp_path_factory.mktemp("pair")
    with NodePair(PairConfig(scene=SCENE, out_dir=out, cycles=CYCLES, progress_every=0)) as pair:
        assert pair.wait_master(120) == 0
    return {role: out / f"{role}.csv" for role in ("master", "slave")}


def test_plot_of_an_offline_session(cli, offline_csv, tmp_path):
    out = tmp_path / "offline.png"
    code, stdout, err = cli("plot", str(offline_csv), "-o", str(out))
    assert code == EXIT_OK, err
    assert stdout.startswith(f"{out}: 300 rows")
    w, h = png_size(out)
    # 5 panels (master, slave, flux, current, contact/safety) of 2.6 in at 100 dpi, 11 in wide
    assert (w, h) == (1100, 1300)
    assert out.stat().st_size > 30_000  # lines drawn, not an empty frame


@pytest.mark.parametrize("role,panels", [("master", 4), ("slave", 4)])
def test_plot_of_a_node_record_csv(cli, node_csvs, role, panels):
    src = node_csvs[role]
    code, stdout, err = cli("plot", str(src))  # default: beside the CSV, suffix .png
    out = src.with_suffix(".png")
    assert code == EXIT_OK, err
    rec = read_recording_csv(src)
    # every row is plotted; the SYNC rows are the master's cycles. A slave starved past its heartbeat
    # consumer time on a loaded machine also records local fallback cycles (sync_cycle -1): extra rows,
    # never missing SYNC rows.
    assert stdout.startswith(f"{out}: {len(rec)} rows")
    assert int(np.count_nonzero(rec.col("sync_cycle") >= 0)) == CYCLES
    assert role == "slave" or len(rec) == CYCLES  # the master is the SYNC producer: no fallback cycles
    # one side: its temperatures, its measured flux, its current, its contact/safety state
    assert png_size(out) == (1100, panels * 260)
    assert out.stat().st_size > 20_000


def test_truncated_csv_names_the_file_and_the_line(cli, node_csvs, tmp_path):
    text = node_csvs["master"].read_text()
    lines = text.rstrip("\n").split("\n")
    cut = tmp_path / "cut.csv"
    cut.write_text("\n".join(lines[:-1]) + "\n" + lines[-1][: len(lines[-1]) // 2])  # a node killed mid-write
    code, stdout, err = cli("plot", str(cut), "-o", str(tmp_path / "cut.png"))
    assert code == EXIT_USAGE and stdout == ""
    assert err.count("\n") == 1
    assert f"cut.csv: line {len(lines)}: expected " in err and "fields" in err
    assert not (tmp_path / "cut.png").exists()


def test_not_a_recording(cli, tmp_path):
    bad = tmp_path / "frames.csv"
    bad.write_text("t_s,cob_id,kind\n0.1,0x80,SYNC\n")  # e.g. the decoded CSV of `telethermo record`
    code, _, err = cli("plot", str(bad))
    assert code == EXIT_USAGE and err.count("\n") == 1
    assert "frames.csv: line 1: expected '# telethermo-recording 1'" in err
    code, _, err = cli("plot", str(tmp_path / "missing.csv"))
    assert code == EXIT_USAGE and "missing.csv: cannot read" in err
    code, _, err = cli("plot", str(tmp_path / "s.blf"))  # a bus log that is not there
    assert code == EXIT_USAGE and "s.blf: no such log file" in err


def test_without_matplotlib_one_line_and_exit_2(cli, offline_csv, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib -> ImportError
    code, _, err = cli("plot", str(offline_csv), "-o", str(tmp_path / "x.png"))
    assert code == EXIT_USAGE
    assert (
        err == "telethermo plot: error: matplotlib is not installed; install the plot extra: "
        "pip install 'telethermo[plot]'\n"
    )
    assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize(
    "tail,line,what",
    [
        (b"0.01,\xff\xfe\n", 5, "not UTF-8 text (byte 0xFF)"),  # binary garbage
        (b"\n0.01,x\n", 6, "column 'm_T_sensor_C': expected a number, got 'x'"),  # a blank line still counts
        (b'0.01,"' + b"x" * 200_000 + b'"\n', 5, "not a CSV row (field larger than field limit"),
    ],
)
def test_damaged_files_name_their_line(cli, tmp_path, tail, line, what):
    bad = tmp_path / "bad.csv"
    bad.write_bytes(b"# telethermo-recording 1\n# meta {}\nt_s,m_T_sensor_C\n0.0,1\n" + tail)
    code, _, err = cli("plot", str(bad))
    assert code == EXIT_USAGE and err.count("\n") == 1 and "Traceback" not in err
    assert f"bad.csv: line {line}: {what}" in err
