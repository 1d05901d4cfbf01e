"""One EDS loader for all (issue 25): the monitor accepted EDS files that `get` and the nodes refuse. A
truncated EDS (an object listed in [ManufacturerObjects] without its section) is read by canopen without a
word; the loader of `get` and the nodes (telethermo.device.eds_info) refuses it, and now the monitor does, in
the same words, exit 2: for a node of the network file and for a further node given by --eds."""

from __future__ import annotations

import json
from pathlib import Path

import can
import pytest

from telethermo import bus_config
from telethermo.cli.main import EXIT_USAGE, main

SRC = Path(bus_config.__file__).resolve().parent


@pytest.fixture
def cli(capsys):
    def run(*argv: str):
        code = main(list(argv))
        out = capsys.readouterr()
        return code, out.out, out.err

    return run


def truncated_eds(path: Path) -> Path:
    text = (SRC / "slave.eds").read_text()
    start = text.index("[2000]")
    path.write_text(text[:start] + text[text.index("\n[", start + 1) + 1 :])
    return path


def a_log(path: Path) -> Path:
    with can.Logger(str(path)) as log:
        for k in range(5):
            log.on_message_received(
                can.Message(
                    timestamp=1.0 + 0.01 * k, arbitration_id=0x080, data=[k + 1], is_extended_id=False
                )
            )
    return path


def test_a_network_files_truncated_eds_is_refused_as_get_refuses_it(cli, tmp_path):
    for name in ("network.toml", "master.eds"):
        (tmp_path / name).write_bytes((SRC / name).read_bytes())
    eds = truncated_eds(tmp_path / "slave.eds")
    net = str(tmp_path / "network.toml")
    message = f"{eds}: 1 listed object(s) have no section (0x2000): truncated or damaged EDS\n"
    code, _, err = cli("get", "slave", "T_sensor_C", "--network", net, "--bus", "virtual:tt-eds-none")
    assert code == EXIT_USAGE and err == f"telethermo get: error: {message}"
    code, _, err = cli("monitor", "--replay", str(a_log(tmp_path / "s.log")), "--network", net, "--json")
    assert code == EXIT_USAGE and err == f"telethermo monitor: error: {message}"


def test_a_further_nodes_truncated_eds_is_refused(cli, tmp_path):
    eds = truncated_eds(tmp_path / "arm.eds")
    code, out, err = cli("monitor", "--replay", str(a_log(tmp_path / "s.log")), "--eds", f"5={eds}", "--json")
    assert code == EXIT_USAGE and out == ""
    assert err == (
        f"telethermo monitor: error: --eds 5={eds}: {eds}: 1 listed object(s) have no section "
        "(0x2000): truncated or damaged EDS\n"
    )
    good = tmp_path / "arm_ok.eds"
    good.write_bytes((SRC / "slave.eds").read_bytes())
    code, out, err = cli(
        "monitor", "--replay", str(tmp_path / "s.log"), "--eds", f"5={good}", "--json", "--no-frames"
    )
    assert code == 0 and json.loads(out.splitlines()[-1])["frames"] == 5
