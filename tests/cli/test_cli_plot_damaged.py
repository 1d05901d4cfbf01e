"""Damaged bus logs (issue 25): a corrupted BLF gave a ``zlib.error`` traceback, a bad ``.log`` line no line
number (and exit 1 in ``monitor``), a truncated BLF was accepted silently. Now each is one line on stderr
naming the file, where (line or byte), what was read before the damage and what was expected, exit 2, in
both ``plot`` and ``monitor --replay``. The logs are written by python-can's own writers and then damaged
as a disk or a killed copy would; the expected counts come from python-can's reader on the same bytes."""

from __future__ import annotations

import io
import struct

import can
import pytest

from telethermo.cli.main import EXIT_USAGE
from tests.support.canframes import pair_frames as frames

pytest.importorskip("matplotlib")

BLF_EXPECTED = "expected a Vector BLF file as its writer closed it"
LOG_EXPECTED = "expected a candump -L line '(TIME) CHANNEL ID#DATA', e.g. '(1.000000) can0 181#00ff'"


def write(path, n: int) -> None:
    with can.Logger(str(path)) as log:
        for m in frames(n):
            log.on_message_received(m)


def blf_objects(data: bytes) -> list[tuple[int, int]]:
    """(offset, end) of each top-level object (the zlib containers) after the 144-byte file header."""
    out, pos = [], 144
    while pos < len(data):
        size = struct.unpack_from("<L", data, pos + 8)[0]
        out.append((pos, pos + size + size % 4))
        pos += size + size % 4
    return out


def read_before(data: bytes) -> str:
    """What python-can's reader yields from ``data``: 'N frames (S s of recording) read before it'."""
    msgs = list(can.BLFReader(io.BytesIO(data)))
    return f"{len(msgs)} frames ({msgs[-1].timestamp - msgs[0].timestamp:.3f} s of recording) read before it"


def both(cli, path):
    """(plot, monitor --replay): each (exit code, stderr)."""
    code_p, _, err_p = cli("plot", str(path))
    code_m, _, err_m = cli("monitor", "--replay", str(path), "--json", "--no-frames")
    return (code_p, err_p), (code_m, err_m)


def assert_one_line(results, message: str) -> None:
    for (code, err), cmd in zip(results, ("plot", "monitor")):
        assert code == EXIT_USAGE, (cmd, err)
        assert err == f"telethermo {cmd}: error: {message}\n", cmd
        assert "Traceback" not in err


def test_a_corrupted_blf_container_is_one_line_with_its_byte(cli, tmp_path):
    good = tmp_path / "good.blf"
    write(good, 3000)  # 9000 frames: several 128 KB containers
    data = bytearray(good.read_bytes())
    objs = blf_objects(bytes(data))
    assert len(objs) >= 3
    second = objs[1]
    data[second[0] + 32 : second[0] + 34] = b"\x00\x00"  # the zlib stream's header of the second container
    bad = tmp_path / "bad.blf"
    bad.write_bytes(bytes(data))
    before = read_before(bytes(data[: objs[1][0]]))
    assert_one_line(
        both(cli, bad),
        f"{bad}: damaged BLF at byte {second[1]} of {len(data)} (zlib.error: Error -3 while "
        f"decompressing data: unknown compression method), {before}; {BLF_EXPECTED}",
    )


def test_a_truncated_blf_is_refused_saying_what_was_read(cli, tmp_path):
    good = tmp_path / "good.blf"
    write(good, 3000)
    data = good.read_bytes()
    cut = tmp_path / "cut.blf"
    cut.write_bytes(data[: len(data) * 2 // 3])  # a copy that stopped
    kept = len(data) * 2 // 3
    assert_one_line(
        both(cli, cut),
        f"{cut}: truncated BLF: {kept} of the {len(data)} bytes its "
        f"header records, {read_before(data[:kept])}; {BLF_EXPECTED}",
    )


def test_a_blf_whose_writer_never_closed_it_is_refused(cli, tmp_path):
    path = tmp_path / "open.blf"
    writer = can.BLFWriter(str(path))
    for m in frames(3000):
        writer.on_message_received(m)
    writer.file.flush()
    snapshot = path.read_bytes()  # what a killed writer leaves: containers, header unfinished
    writer.stop()
    killed = tmp_path / "killed.blf"
    killed.write_bytes(snapshot)
    assert_one_line(
        both(cli, killed),
        f"{killed}: unfinished BLF: its header was never completed (the "
        f"writer did not close it), {read_before(snapshot)}; {BLF_EXPECTED}",
    )


def test_a_bad_candump_line_is_named_by_its_number_in_plot_and_monitor(cli, tmp_path):
    good = tmp_path / "good.log"
    write(good, 20)
    lines = good.read_text().splitlines()
    lines[10] = "(1000.1) vcan0"  # line 11: no frame field
    bad = tmp_path / "bad.log"
    bad.write_text("\n".join(lines) + "\n")
    assert_one_line(
        both(cli, bad),
        f"{bad}:11: damaged line (ValueError: not enough values to unpack (expected 3, got 2)), "
        f"10 frames (0.030 s of recording) read before it; {LOG_EXPECTED}",
    )


def test_a_damaged_record_csv_row_is_exit_2_in_monitor_too(cli, tmp_path):
    path = tmp_path / "s.log.csv"
    path.write_text(
        "t_s,cob_id,kind,node,dlc,data,text,fields\n1.0,0x080,SYNC,,1,01,SYNC #1,{}\n"
        "1.01,0x080,SYNC,,3,02,SYNC #2,{}\n"
    )
    code, _, err = cli("monitor", "--replay", str(path), "--json", "--no-frames")
    assert code == EXIT_USAGE and err == (
        f"telethermo monitor: error: {path}:3: damaged row (dlc 3 but 1 data bytes), "
        "1 frame (0.000 s of recording) read before it\n"
    )
