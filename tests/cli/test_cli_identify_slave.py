"""``telethermo identify slave`` inside a running telepresence pair (two node processes on the hub, lockstep,
sim/scenes/pads_in_air.toml): the master, in telepresence, is put in idle for the experiment and back
after; the slave's model is loaded into the slave, and the master keeps its own (none)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from telethermo.nodes.launch import NodePair, PairConfig, wait_for
from telethermo.cli.main import EXIT_OK, main

pytestmark = pytest.mark.slow
SCENE = Path(__file__).resolve().parents[2] / "sim" / "scenes" / "pads_in_air.toml"


def cli(capsys, *argv):
    code = main(list(argv))
    o = capsys.readouterr()
    return code, o.out, o.err


def get(capsys, bus, role, name):
    code, out, err = cli(capsys, "get", "--bus", bus, role, name)
    assert code == EXIT_OK, err
    return out.split(" = ", 1)[1].split()[0]


def test_identify_the_slave_of_a_running_pair(tmp_path, capsys):
    pair = NodePair(
        PairConfig(
            scene=SCENE, out_dir=tmp_path, timing="lockstep", cycles=0, mode="telepresence", progress_every=0
        )
    )
    with pair:
        bus = pair.bus
        assert wait_for(lambda: cli(capsys, "status", "--bus", bus, "--timeout", "0.3")[0] == EXIT_OK, 60)
        assert get(capsys, bus, "master", "mode") == get(capsys, bus, "slave", "mode") == "1"
        code, out, err = cli(
            capsys, "identify", "slave", "--bus", bus, "--samples", "10000", "--validation", "1000", "--quiet"
        )
        assert code == EXIT_OK, err
        assert "master (node 1): telepresence -> idle for the experiment" in err
        assert re.search(r"model loaded into slave \(node 2\): CRC-32 0x[0-9A-F]{8} verified", out)
        worst = float(re.search(r"held-out free run\s+worst ([0-9.]+) °C", out).group(1))
        assert worst < 0.1
        # both back in telepresence; the slave runs its new model, the master still none
        assert get(capsys, bus, "master", "mode") == get(capsys, bus, "slave", "mode") == "1"
        assert (
            get(capsys, bus, "slave", "model_status") == "1"
            and get(capsys, bus, "master", "model_status") == "0"
        )
        # with the model estimator driving the pad in telepresence, a model swap is refused (its new predictor
        # would start at rest under load); with the flux estimator it is taken
        assert cli(capsys, "set", "--bus", bus, "slave", "estimator", "0")[0] == EXIT_OK
        code, _, err = cli(capsys, "set", "--bus", bus, "slave", "model_command", "1")
        assert code == 1 and "0x08000022" in err
        assert cli(capsys, "set", "--bus", bus, "slave", "estimator", "1")[0] == EXIT_OK
        assert cli(capsys, "set", "--bus", bus, "slave", "model_command", "1")[0] == EXIT_OK
        # the pair is still coupled: the master receives the slave's PDOs, no peer trip on either side
        assert (
            get(capsys, bus, "master", "peer_alive") == "True"
            and get(capsys, bus, "slave", "peer_alive") == "True"
        )
        assert get(capsys, bus, "master", "safety_state") in ("0", "1")
        assert get(capsys, bus, "slave", "safety_state") in ("0", "1")
