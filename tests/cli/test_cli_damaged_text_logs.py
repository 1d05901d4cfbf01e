"""Damaged ASC, TRC and CSV logs (docs/cli.md: "a damaged log of any format ends the replay with one line,
exit 2"). python-can's ASC and TRC readers step over a line they cannot read (a TRC one with a warning that
reached stderr), and every text reader took a last line cut mid-way as a shorter frame: a log cut by a
killed copy, or with a garbage line, was replayed and plotted with exit 0. Now each is one line naming the
file, the line (1-based) and the frames read before it, in ``plot``, ``monitor --replay`` and ``replay``.
The logs are written by python-can's own writers, then cut or edited; the expected frame counts come from
python-can's reader on the lines before the damage."""

from __future__ import annotations

import time

import can
import pytest

from telethermo.cli.main import EXIT_USAGE
from tests.support.canframes import pair_frames as frames
from telethermo.monitor.logread import ReplayError, is_record_csv, read_log

pytest.importorskip("matplotlib")

READERS = {".asc": can.ASCReader, ".trc": can.TRCReader, ".csv": can.CSVReader, ".log": can.CanutilsLogReader}
TEXT = (".asc", ".trc", ".log.csv", ".log")


def write(path, n: int) -> list[str]:
    """The log of n cycles by python-can's writer for its extension; its lines, ends kept."""
    with can.Logger(str(path)) as log:
        for m in frames(n):
            log.on_message_received(m)
    with open(path, newline="") as fh:
        return fh.readlines()


def before(tmp_path, ext: str, lines: list[str]) -> str:
    """What python-can's reader gets from ``lines``: 'N frames (S s of recording) read before it'."""
    part = tmp_path / f"part{ext}"
    with open(part, "w", newline="") as fh:
        fh.write("".join(lines))
    with READERS[part.suffix](str(part)) as reader:
        msgs = list(reader)
    return f"{len(msgs)} frames ({msgs[-1].timestamp - msgs[0].timestamp:.3f} s of recording) read before it"


def three(cli, path, tmp_path) -> list[tuple[str, int, str]]:
    """(command, exit code, stderr) of monitor --replay, plot (a bus log, a record CSV) and replay onto a
    virtual bus."""
    channel = f"tt-damaged-{time.monotonic_ns()}"
    out = [("monitor", *cli("monitor", "--replay", str(path), "--json", "--no-frames")[::2])]
    if not path.name.endswith(".log.csv") or is_record_csv(path):  # plot reads no python-can CSV
        out.append(("plot", *cli("plot", str(path), "-o", str(tmp_path / "p.png"))[::2]))
    listener = can.Bus(interface="virtual", channel=channel)
    try:
        code, _, err = cli("replay", str(path), "--bus", f"virtual:{channel}", "--speed", "0")
    finally:
        listener.shutdown()
    out.append(("replay", code, err.split("\n", 1)[1]))  # after its "replaying ..." line
    return out


def assert_refused(results, message: str) -> None:
    for cmd, code, err in results:
        assert code == EXIT_USAGE, (cmd, err)
        if cmd == "replay":
            assert err.startswith(f"telethermo replay: error: {message}; ") and err.count("\n") == 1, err
            assert err.endswith(" frames were sent\n"), err
        else:
            assert err == f"telethermo {cmd}: error: {message}\n", (cmd, err)


@pytest.mark.parametrize("ext", TEXT)
def test_a_log_cut_mid_line_is_refused_naming_the_last_line(cli, tmp_path, ext):
    lines = write(tmp_path / f"good{ext}", 100)
    cut = tmp_path / f"cut{ext}"
    last = lines[200].rstrip("\r\n")
    kept = last[: len(last) - 4]  # a copy that stopped mid-way through line 201
    cut.write_bytes("".join(lines[:200]).encode() + kept.encode())
    with pytest.raises(ReplayError) as err:
        list(read_log(cut))
    message = str(err.value)
    assert message.startswith(f"{cut}:201: truncated line (the file ends mid-"), message
    assert before(tmp_path, ext, lines[:200]) in message
    assert_refused(three(cli, cut, tmp_path), message)


@pytest.mark.parametrize("ext", TEXT)
def test_a_log_cut_inside_its_last_byte_or_between_two_is_refused(tmp_path, ext):
    lines = write(tmp_path / f"good{ext}", 20)
    last = lines[40].rstrip("\r\n")
    for drop in (1, 2, 3):  # half of the last data byte, all of it, and its separator
        cut = tmp_path / f"cut{drop}{ext}"
        cut.write_bytes("".join(lines[:40]).encode() + last[:-drop].encode())
        with pytest.raises(ReplayError, match=rf"^{cut}:41: truncated line \(the file ends mid-"):
            list(read_log(cut))


@pytest.mark.parametrize("ext", [".asc", ".trc"])
def test_a_garbage_line_python_can_steps_over_is_named(cli, tmp_path, ext):
    lines = write(tmp_path / f"good{ext}", 590)  # 1770 frames
    bad = tmp_path / f"bad{ext}"
    bad.write_text("".join(lines[:100]) + "garbage line here\n" + "".join(lines[101:]))
    message = (
        f"{bad}:101: damaged line (neither a frame nor a known {ext} line: 'garbage line here'), "
        f"{before(tmp_path, ext, lines[:100])}; expected "
    )
    with pytest.raises(ReplayError, match="^" + message.replace("(", r"\(").replace(")", r"\)")):
        list(read_log(bad))
    results = three(cli, bad, tmp_path)
    assert all(code == EXIT_USAGE and message in err and err.count("\n") == 1 for _, code, err in results)


def test_a_trc_python_can_cannot_parse_is_damaged_and_its_warning_not_printed(cli, tmp_path):
    bad = tmp_path / "garbage.trc"
    bad.write_text("foo")
    message = (
        f"{bad}:1: damaged line (python-can: TRCReader: Failed to parse message 'foo'), no frame before it; "
        "expected a PEAK trace line, e.g. '1 1000.000 DT 0181 Rx 2 00 FF'"
    )
    assert_refused(three(cli, bad, tmp_path), message)
    lines = write(tmp_path / "good.trc", 20)
    short = tmp_path / "short.trc"  # a frame line without its data columns, in the middle
    short.write_text("".join(lines[:30]) + " ".join(lines[30].split()[:4]) + "\n" + "".join(lines[31:]))
    with pytest.raises(ReplayError, match=rf"^{short}:31: damaged line \(python-can: TRCReader: Failed"):
        list(read_log(short))


def test_a_byte_that_is_not_utf8_is_named_by_its_own_line(cli, tmp_path):
    lines = write(tmp_path / "good.asc", 20)
    bad = tmp_path / "bad.asc"
    bad.write_bytes("".join(lines[:11]).encode() + b"\xff\xfe garbage\n" + "".join(lines[12:]).encode())
    code, _, err = cli("plot", str(bad), "-o", str(tmp_path / "p.png"))
    assert code == EXIT_USAGE
    assert err.startswith(f"telethermo plot: error: {bad}:12: damaged line (UnicodeDecodeError: ")
    assert err.count("\n") == 1


@pytest.mark.parametrize("ext", TEXT)
def test_a_whole_log_of_python_cans_writer_reads_fully_and_quietly(cli, tmp_path, capsys, ext):
    good = tmp_path / f"good{ext}"
    write(good, 590)
    assert len(list(read_log(good))) == 1770
    assert capsys.readouterr().err == ""
    code, out, err = cli("monitor", "--replay", str(good), "--json", "--no-frames")
    assert code == 0 and err == ""
    empty = tmp_path / f"empty{ext}"  # the writer of a recording that got no frame
    write(empty, 0)
    assert list(read_log(empty)) == [] and capsys.readouterr().err == ""


def test_a_last_line_whole_but_without_its_end_of_line_is_read(tmp_path):
    for ext in (".asc", ".trc", ".log.csv"):
        lines = write(tmp_path / f"good{ext}", 20)
        if ext == ".asc":
            lines = lines[:-1]  # no "End TriggerBlock": a frame line last
        edited = tmp_path / f"edited{ext}"
        edited.write_text("".join(lines).rstrip("\r\n"))
        assert len(list(read_log(edited))) == 60, ext


def test_a_record_csv_cut_mid_row_is_refused(cli, tmp_path):
    head = "t_s,cob_id,kind,node,dlc,data,text,fields\n"
    rows = '1.0,0x080,SYNC,,1,01,SYNC #1,{}\n1.01,0x181,PDO,1,2,0102,TPDO1 node 1,"{""x"": 1}"\n'
    whole = tmp_path / "whole.log.csv"
    whole.write_text(head + rows.rstrip("\n"))  # a whole last row without its end of line is read
    assert len(list(read_log(whole))) == 2
    for kept, why in ((-16, "7 of 8 columns"), (-3, "its fields column is cut")):
        cut = tmp_path / f"cut{-kept}.log.csv"
        cut.write_text(head + rows.rstrip("\n")[:kept])
        message = (
            f"{cut}:3: truncated row (the file ends mid-row: {why}), "
            "1 frame (0.000 s of recording) read before it"
        )
        assert_refused(three(cli, cut, tmp_path), message)
