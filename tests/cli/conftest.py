"""Two real CiA 301 devices (telethermo.device.Device over canopen LocalNode, from
bus_config's EDS and network settings) on a python-can virtual bus, for the CLI's tests."""

from __future__ import annotations

import contextlib
import io
import itertools
import time

from pathlib import Path

import canopen
import pytest

from telethermo.nodes.launch import HubProcess, start_lone_node, stop_process, wait_for

from telethermo.device.device import Device
from telethermo.device.netconfig import load_network
from telethermo.cli.main import main

_n = itertools.count()


class Nodes:
    def __init__(self) -> None:
        self.channel = f"tt-cli-{next(_n)}-{time.monotonic_ns()}"
        self.net = load_network()
        self.networks, self.devices = [], {}
        for role in ("master", "slave"):
            nw = canopen.Network()
            nw.NOTIFIER_CYCLE = 0.05  # quick shutdown
            nw.connect(interface="virtual", channel=self.channel)
            cfg = self.net.node(role)
            dev = Device(nw, cfg.node_id, cfg.eds, settings=self.net.device_settings(role))
            dev.start()
            self.networks.append(nw)
            self.devices[role] = dev

    @property
    def bus(self) -> list[str]:
        return ["--bus", f"virtual:{self.channel}"]

    def close(self) -> None:
        for dev in self.devices.values():
            dev.close()
        for nw in self.networks:
            nw.disconnect()


@pytest.fixture
def nodes():
    n = Nodes()
    try:
        yield n
    finally:
        n.close()


@pytest.fixture
def cli(capsys):
    """Run ``telethermo ARGS`` in-process: (exit code, stdout, stderr)."""

    def run(*argv: str):
        code = main(list(argv))
        out = capsys.readouterr()
        return code, out.out, out.err

    return run


FREE_PAD_SCENE = Path(__file__).resolve().parents[2] / "sim" / "scenes" / "free_pad_identification.toml"


@pytest.fixture(scope="module")
def lone_master(tmp_path_factory):
    """A master node process alone on our hub (a pad in air, lockstep, idle), answering SDO: (bus string, its
    folder). Every test of a module may run first (``-k``), so the fixture waits for the node, not a test."""
    out = tmp_path_factory.mktemp("lone-master")
    hub = HubProcess(log_path=out / "hub.log")
    hub.start()
    proc = start_lone_node("master", FREE_PAD_SCENE, out, "--bus", hub.bus)

    def answers() -> bool:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            return main(["get", "--bus", hub.bus, "--timeout", "0.3", "master", "mode"]) == 0

    try:
        assert wait_for(answers, 60), f"the lone master does not answer SDO (its log: {out})"
        yield hub.bus, out
    finally:
        stop_process(proc)
        hub.stop()
