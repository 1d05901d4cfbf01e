"""``telethermo plot FILE.log``: a bus log's PDO values decoded by the shipped EDS mappings (issue 13: nothing
plotted a bus log). The log is written by python-can's own Logger with frames laid out as the EDS maps
TPDO1 (estimate_C, Q_W as REAL32) of both nodes, plus an EMCY; the decoded series must equal the values
written, and the picture is a real PNG."""

from __future__ import annotations

import struct

import can
import pytest

from telethermo.cli.main import EXIT_OK, EXIT_USAGE
from telethermo.cli.monitor_setup import monitor_config
from telethermo.device.netconfig import load_network
from telethermo.monitor.busplot import decode_bus_log

pytest.importorskip("matplotlib")


def write_log(path, n=50):
    """n cycles: SYNC, master TPDO1 (0x181), slave TPDO1 (0x182); an EMCY 0x8130 from the master at cycle
    30."""
    with can.Logger(str(path)) as log:
        for k in range(n):
            t = 1000.0 + 0.01 * k
            log.on_message_received(
                can.Message(
                    timestamp=t, arbitration_id=0x080, data=bytes([k % 240 + 1]), is_extended_id=False
                )
            )
            for nid, base in ((1, 33.0), (2, 25.0)):
                data = struct.pack("<ff", base + 0.01 * k, -0.1 * nid)
                log.on_message_received(
                    can.Message(
                        timestamp=t + 0.001 * nid, arbitration_id=0x180 + nid, data=data, is_extended_id=False
                    )
                )
            if k == 30:
                log.on_message_received(
                    can.Message(
                        timestamp=t + 0.005,
                        arbitration_id=0x081,
                        data=bytes([0x30, 0x81, 0x11, 0, 0, 0, 0, 0]),
                        is_extended_id=False,
                    )
                )


def test_the_pdo_values_come_back_by_the_eds_mapping(tmp_path):
    log = tmp_path / "s.log"
    write_log(log)
    cfg = monitor_config(load_network())
    data = decode_bus_log(
        can.LogReader(str(log)),
        {k: n.od for k, n in cfg.nodes.items()},
        {k: n.name for k, n in cfg.nodes.items()},
    )
    ts, ys = data.series[("master", "estimate_C")]
    assert (
        len(ys) == 50 and ys[0] == pytest.approx(33.0, abs=1e-5) and ys[-1] == pytest.approx(33.49, abs=1e-5)
    )
    assert data.series[("slave", "Q_W")][1][0] == pytest.approx(-0.2, abs=1e-6)
    assert ts[1] - ts[0] == pytest.approx(0.01, abs=1e-6)
    assert [(who, code) for _, who, code in data.emcys] == [("master", 0x8130)]


def test_plot_writes_a_png_of_a_bus_log(cli, tmp_path):
    log = tmp_path / "s.log"
    write_log(log)
    code, out, err = cli("plot", str(log))
    assert code == EXIT_OK, err
    png = tmp_path / "s.png"
    assert (
        png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and "151 frames" in out and "1 EMCY" in out
    )  # 50 × (SYNC + 2 TPDO1) + EMCY


def test_a_log_without_pdos_is_one_line(cli, tmp_path):
    log = tmp_path / "empty.log"
    with can.Logger(str(log)) as lg:
        lg.on_message_received(
            can.Message(timestamp=1.0, arbitration_id=0x080, data=b"", is_extended_id=False)
        )
    code, _, err = cli("plot", str(log))
    assert code == EXIT_USAGE and "no numeric PDO value in 1 frames" in err and err.count("\n") == 1


def tpdo4(t: float, node: int, counter: int, safety: int, mode: int) -> can.Message:
    """TPDO4 of the shipped EDS: cycle_counter u32, safety_state u8, mode u8, contact, peer_alive."""
    return can.Message(
        timestamp=t,
        arbitration_id=0x480 + node,
        is_extended_id=False,
        data=struct.pack("<IBBBB", counter, safety, mode, 1, 1),
    )


def test_codes_and_counters_have_panels_of_their_own(tmp_path):
    """Issue 25: cycle_counter (~24,000) shared the axis of the 0..11 codes, which then read as a flat
    line."""
    from telethermo.monitor.busplot import bus_log_figure

    msgs = [tpdo4(10.0 + 0.01 * k, 1, 24_000 + k, k // 20, 1 + k // 50) for k in range(100)]
    cfg = monitor_config(load_network())
    data = decode_bus_log(
        msgs, {k: n.od for k, n in cfg.nodes.items()}, {k: n.name for k, n in cfg.nodes.items()}
    )
    assert data.panels[("master", "cycle_counter")] == "count"
    assert data.panels[("master", "safety_state")] == data.panels[("master", "mode")] == "code"
    fig = bus_log_figure(data, "t")
    by_label = {ax.get_ylabel(): ax for ax in fig.axes}
    assert set(by_label) == {"state, code", "count"}
    codes, counts = by_label["state, code"], by_label["count"]
    assert sorted(line.get_label() for line in codes.get_lines()) == ["master mode", "master safety_state"]
    assert [line.get_label() for line in counts.get_lines()] == ["master cycle_counter"]
    assert codes.get_ylim()[1] < 10 and counts.get_ylim()[0] > 23_000  # neither squashes the other


def test_plot_reads_the_csv_that_record_writes(cli, tmp_path):
    """Issue 25: `plot` refused `record`'s own decoded CSV (it expected a session recording)."""
    from telethermo.monitor.record import Recorder
    from telethermo.monitor.state import Monitor

    cfg = monitor_config(load_network())
    log = tmp_path / "s.log"
    rec = Recorder(log, tmp_path / "s.log.csv", Monitor(cfg))
    write_log(tmp_path / "src.log")
    for m in can.LogReader(str(tmp_path / "src.log")):
        rec.on_message_received(m)
    assert rec.stop() == 151
    code, out, err = cli("plot", str(tmp_path / "s.log.csv"))
    assert code == EXIT_OK, err
    assert out.startswith(f"{tmp_path / 's.log.png'}: 151 frames, 4 series, 1 EMCY")
    assert (tmp_path / "s.log.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
