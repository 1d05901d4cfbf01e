"""``telethermo identify master`` over a real SocketCAN vcan: the master program alone (a pad in air),
the CLI in this process, candump (can-utils) as an independent witness of the stream."""

from __future__ import annotations

import re
import struct
import time
from pathlib import Path

import numpy as np
import pytest

from telethermo.nodes.launch import start_lone_node, stop_process, wait_for
from telethermo.cli.main import EXIT_OK, main
from telethermo.ident import load_model, odmodel

pytestmark = [pytest.mark.vcan, pytest.mark.slow]

SCENE = Path(__file__).resolve().parents[2] / "sim" / "scenes" / "free_pad_identification.toml"
# orders 3,3,1,1: well determined by a short experiment (2,000 training samples: 12 of 12 experiments stable,
# see docs/identification.md), so that the run fits the slow VM
N_TRAIN, N_VAL, REST, ORDERS = 2_000, 500, 200, "3,3,1,1"


def cli(capsys, *argv):
    code = main(list(argv))
    o = capsys.readouterr()
    return code, o.out, o.err


def test_identify_a_live_node_on_vcan(vcan_channel, candump, tmp_path, slow_network, capsys):
    net = ["--network", str(slow_network), "--timeout", "5"]
    node = start_lone_node("master", SCENE, tmp_path, "--network", str(slow_network))
    try:
        assert wait_for(lambda: cli(capsys, "status", *net, "master")[0] == EXIT_OK, 300, poll_s=1.0), (
            tmp_path / "master-stderr.log"
        ).read_text()
        dump = candump()
        time.sleep(1.0)  # candump gives no sign that it listens: time for it to bind its socket
        code, out, err = cli(
            capsys,
            "identify",
            "master",
            *net,
            "--samples",
            str(N_TRAIN),
            "--validation",
            str(N_VAL),
            "--orders",
            ORDERS,
            "--out",
            str(tmp_path / "m.json"),
            "--save-data",
            str(tmp_path / "m.csv"),
            "--quiet",
        )
        time.sleep(0.5)  # candump shows nothing until it stops: time to read the last frames
        frames = dump.stop()
        assert code == EXIT_OK, err
        crc = int(re.search(r"CRC-32 0x([0-9A-F]{8}) verified", out).group(1), 16)
        assert crc == odmodel.od_crc32(odmodel.model_entries(load_model(tmp_path / "m.json")))
        code, out, err = cli(capsys, "get", *net, "master", "model_crc32", "0x1A02:1", "0x1802:2", "mode")
        assert code == EXIT_OK, err
        vals = [line.split(" = ", 1)[1].split()[0] for line in out.splitlines()]
        assert vals == [f"0x{crc:08X}", "0x21010020", "10", "0"]  # CRC and mapping entry in hex
    finally:
        stop_process(node)
    total = REST + N_TRAIN + N_VAL
    # candump saw the samples of the experiment numbered 1..total, in order, in TPDO2 (0x281: number,
    # T_sensor_C) after the
    # remapping (in this slow VM under load a reader's socket may overflow: candump's too, even with its 8 MB
    # buffer, so 90 % of them are required here; the CLI fetched its own lost ones by SDO, and all of them
    # are in its CSV); their temperatures are what the CLI recorded,
    # bit for bit (REAL32). (TPDO2's EDS mapping starts with T_sensor_C: its REAL32 bits read as a number are
    # ~1.1e9, never a sample number; TPDO4's starts with the cycle counter, which can be one.)
    tp3 = [struct.unpack("<If", d) for i, d in frames if i == 0x281 and len(d) == 8]
    numbered = [(k, q) for k, q in tp3 if 1 <= k <= total]
    ks = [k for k, _ in numbered]
    assert ks == sorted(set(ks)) and len(ks) >= 0.9 * total
    rows = [line.split(",") for line in (tmp_path / "m.csv").read_text().splitlines() if line[:1].isdigit()]
    assert len(rows) == total
    q_csv = np.array([float(r[4]) for r in rows], dtype=np.float32)
    np.testing.assert_array_equal(
        np.array([q for _, q in numbered], dtype=np.float32), q_csv[np.array(ks) - 1]
    )
    # the remapping went by CiA 301 on the bus: PDO invalid (COB-ID bit 31), mapping written, valid again
    sdo_writes = [d for i, d in frames if i == 0x601 and d[0] & 0xE0 == 0x20]
    idx = [(int.from_bytes(d[1:3], "little"), d[3], int.from_bytes(d[4:8], "little")) for d in sdo_writes]
    assert (0x1802, 1, 0x80000381) in idx and (0x1A02, 1, 0x28070020) in idx and (0x1802, 1, 0x381) in idx
