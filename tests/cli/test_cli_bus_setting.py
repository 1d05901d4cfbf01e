"""One bus setting, in python-can's order: --bus or -i/-c/-b, then CAN_INTERFACE/CAN_CHANNEL/CAN_BITRATE,
then python-can's config file (~/.canrc, sections), then network.toml; a running hub publishes where it
listens so that a command needs no flag. Real CiA 301 devices on python-can virtual buses (and on a real
telethermo-hub process), the real CLI, a temporary HOME and environment."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import can.util
import canopen
import pytest

from telethermo.bus_config import path as cfg_path
from tests.support.busenv import isolate_bus_settings
from telethermo.device.netconfig import load_network
from telethermo.cli.main import EXIT_FAIL, EXIT_OK, EXIT_USAGE
from telethermo.transport.bus import TransportError
from telethermo.transport.published import publish, running, state_file
from telethermo.transport.resolve import resolve_bus

pytestmark = pytest.mark.slow  # starts processes


@pytest.fixture(autouse=True)
def isolated(tmp_path, monkeypatch):
    """A HOME, runtime dir and working directory of our own; no CAN_* variables; python-can's config files
    only under that HOME (not /etc/can.conf of this machine)."""
    return isolate_bus_settings(tmp_path, monkeypatch)


def canrc(home: Path, text: str) -> None:
    (home / ".canrc").write_text(text)


def network_file(tmp_path: Path, interface: str, channel: str, options: str = "") -> Path:
    """The shipped network.toml with another [bus] (and [bus.options] lines), the shipped EDS beside it."""
    import shutil

    text = cfg_path("network.toml").read_text()
    for old, new in (
        ('interface = "virtual"', f'interface = "{interface}"'),
        ('channel = "telethermo"', f'channel = "{channel}"'),
        ("[bus.options]\n", f"[bus.options]\n{options}\n"),
    ):
        assert old in text
        text = text.replace(old, new, 1)
    folder = tmp_path / "net"
    folder.mkdir(exist_ok=True)
    for eds in ("master.eds", "slave.eds"):
        shutil.copy(cfg_path(eds), folder / eds)
    (folder / "network.toml").write_text(text)
    return folder / "network.toml"


# --- the order, on the resolver --------------------------------------------------------------------
def test_each_layer_wins_over_the_next(isolated, tmp_path, monkeypatch):
    net = load_network(network_file(tmp_path, "virtual", "from-network"))
    r = resolve_bus(net)
    assert (r.settings.describe(), r.source) == ("virtual:from-network", str(net.path))
    assert r.settings.bitrate == 1_000_000

    canrc(
        isolated,
        "[default]\ninterface = virtual\nchannel = from-default\nbitrate = 500000\n"
        "[telethermo]\nchannel = from-section\n",
    )
    r = resolve_bus(net)
    assert r.settings.describe() == "virtual:from-section" and r.settings.bitrate == 500_000
    assert r.source == f"[default] of {isolated / '.canrc'}".replace(str(isolated), "~")

    monkeypatch.setenv("CAN_INTERFACE", "virtual")
    monkeypatch.setenv("CAN_CHANNEL", "from-env")
    monkeypatch.setenv("CAN_BITRATE", "250000")
    r = resolve_bus(net)
    assert r.settings.describe() == "virtual:from-env" and r.settings.bitrate == 250_000
    assert r.source.startswith("environment")
    monkeypatch.setenv("CAN_CHANNEL_telethermo", "from-env-context")
    assert resolve_bus(net).settings.channel == "from-env-context"

    r = resolve_bus(net, interface="virtual", channel="from-flags", bitrate=125_000)
    assert (
        r.settings.describe() == "virtual:from-flags"
        and r.settings.bitrate == 125_000
        and r.source == "-i/-c/-b"
    )
    # a flag sets one key; the others still come from the next layers (python-can merges key by key)
    r = resolve_bus(net, channel="only-channel")
    assert r.settings.describe() == "virtual:only-channel" and r.settings.bitrate == 250_000
    r = resolve_bus(net, bus="virtual:from-bus")
    assert (r.settings.describe(), r.source, r.settings.bitrate) == ("virtual:from-bus", "--bus", 250_000)
    with pytest.raises(TransportError, match="--bus and -i/-c both name the bus"):
        resolve_bus(net, bus="virtual:x", channel="y")


def test_the_network_files_channel_belongs_to_its_interface(tmp_path, monkeypatch):
    net = load_network(network_file(tmp_path, "virtual", "from-network"))
    monkeypatch.setenv("CAN_INTERFACE", "socketcan")
    with pytest.raises(TransportError, match="interface 'socketcan' but no channel"):
        resolve_bus(net)
    monkeypatch.setenv("CAN_CONFIG", json.dumps({"channel": "vcan7", "receive_own_messages": True}))
    r = resolve_bus(net)
    assert r.settings.describe() == "socketcan:vcan7" and dict(r.settings.options) == {
        "receive_own_messages": True
    }
    # a socketcand network file: host and port come with its interface
    net = load_network(network_file(tmp_path, "socketcand", "telethermo", 'host = "127.0.0.1"\nport = 29999'))
    monkeypatch.delenv("CAN_INTERFACE")
    monkeypatch.delenv("CAN_CONFIG")
    assert resolve_bus(net).settings.describe() == "socketcand://127.0.0.1:29999/telethermo"


@pytest.mark.parametrize("where", ["--bus", "-i", "env", "canrc", "network"])
def test_an_unknown_interface_is_one_line_and_exit_2(where, isolated, tmp_path, monkeypatch, cli):
    argv = ["get", "--timeout", "0.1", "master", "kp_A_per_C"]
    if where == "--bus":
        argv[1:1] = ["--bus", "kvasr:0"]
    elif where == "-i":
        argv[1:1] = ["-i", "kvasr", "-c", "0"]
    elif where == "env":
        monkeypatch.setenv("CAN_INTERFACE", "kvasr")
    elif where == "canrc":
        canrc(isolated, "[default]\ninterface = kvasr\nchannel = 0\n")
    else:
        argv[1:1] = ["--network", str(network_file(tmp_path, "kvasr", "0"))]
    code, out, err = cli(*argv)
    assert code == EXIT_USAGE, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert "unknown python-can interface 'kvasr'; expected one of" in err and "socketcan" in err


def test_a_node_program_refuses_an_unknown_interface_in_one_line(isolated):
    scene = Path(__file__).resolve().parents[2] / "sim" / "scenes" / "free_pad_identification.toml"
    env = dict(os.environ, CAN_INTERFACE="kvasr", CAN_CHANNEL="0")
    proc = subprocess.run(
        [sys.executable, "-m", "telethermo.nodes.master", "--scene", str(scene), "--cycles", "1"],
        capture_output=True,
        text=True,
        env=env,
        timeout=60,
    )
    assert proc.returncode == EXIT_USAGE, proc.stderr
    assert proc.stderr.strip().splitlines() == [
        "telethermo-master: error: environment (CAN_INTERFACE, CAN_CHANNEL, CAN_BITRATE, CAN_CONFIG): "
        "bus.interface: "
        "unknown python-can interface 'kvasr'; expected one of " + ", ".join(sorted(can.VALID_INTERFACES))
    ]


# --- the order, end to end: `telethermo get` reads from real devices on the bus each layer names -----------
def test_get_finds_the_nodes_through_each_layer(nodes, isolated, tmp_path, monkeypatch, cli):
    ok = ["get", "master", "kp_A_per_C"]
    quick_fail = ["get", "--timeout", "0.2", "master", "kp_A_per_C"]
    # network.toml naming the nodes' bus
    net = str(network_file(tmp_path, "virtual", nodes.channel))
    code, out, err = cli("get", "--network", net, "master", "kp_A_per_C")
    assert code == EXIT_OK and "kp_A_per_C = " in out, err
    # the config file beats the network file (its bus has no node)
    canrc(isolated, "[default]\ninterface = virtual\nchannel = nobody-here\n")
    assert cli("get", "--network", net, "--timeout", "0.2", "master", "kp_A_per_C")[0] == EXIT_FAIL
    # ... and reaches the nodes when it names their bus; its [telethermo] section beats [default]
    canrc(
        isolated,
        f"[default]\ninterface = virtual\nchannel = nobody-here\n[telethermo]\nchannel = {nodes.channel}\n",
    )
    assert cli(*ok)[0] == EXIT_OK
    # the environment beats the config file
    monkeypatch.setenv("CAN_CHANNEL", "nobody-here")
    canrc(isolated, f"[default]\ninterface = virtual\nchannel = {nodes.channel}\n")
    assert cli(*quick_fail)[0] == EXIT_FAIL
    monkeypatch.setenv("CAN_CHANNEL", nodes.channel)
    canrc(isolated, "[default]\ninterface = virtual\nchannel = nobody-here\n")
    assert cli(*ok)[0] == EXIT_OK
    # flags beat the environment
    monkeypatch.setenv("CAN_CHANNEL", "nobody-here")
    assert cli("get", "-c", nodes.channel, "master", "kp_A_per_C")[0] == EXIT_OK
    assert (
        cli("get", "-i", "virtual", "-c", "nobody-here", "--timeout", "0.2", "master", "kp_A_per_C")[0]
        == EXIT_FAIL
    )
    assert cli("get", "--bus", f"virtual:{nodes.channel}", "master", "kp_A_per_C")[0] == EXIT_OK


# --- a running hub: no flag needed --------------------------------------------------------------------
def test_a_running_hub_is_found_with_no_flag_and_forgotten_when_it_stops(isolated, cli):
    from telethermo.nodes.launch import HubProcess
    from telethermo.device.device import Device

    code, out, err = cli("get", "--timeout", "0.1", "master", "kp_A_per_C")
    assert (
        code == EXIT_FAIL and "no hub or session is running" in err and "bus inside this process only" in err
    )
    hub = HubProcess(publish=True)
    hub.start()
    nw = None
    dev = None
    try:
        doc = json.loads(state_file().read_text())
        assert doc["bus"] == hub.bus and doc["pid"] == hub.proc.pid and doc["by"] == "telethermo-hub"
        assert state_file().parent.parent == isolated.parent / "run"
        # a real master device (CiA 301 over canopen) on the hub, as a node process would be
        net = load_network()
        nw = canopen.Network()
        nw.connect(
            interface="socketcand", host="127.0.0.1", port=hub.port, channel="telethermo", tcp_tune=True
        )
        cfg = net.node("master")
        dev = Device(nw, cfg.node_id, cfg.eds, settings=net.device_settings("master"))
        dev.start()
        dev.write("kp_A_per_C", 2.5)
        code, out, err = cli("get", "master", "kp_A_per_C")
        assert code == EXIT_OK and "kp_A_per_C = 2.5 A/degC" in out and err == "", err
        # something configured wins over the published hub
        assert cli("get", "-c", "elsewhere", "--timeout", "0.1", "master", "kp_A_per_C")[0] == EXIT_FAIL
    finally:
        if dev is not None:
            dev.close()
        if nw is not None:
            nw.disconnect()
        hub.stop()
    assert not state_file().exists() and running() is None


def test_a_stale_or_damaged_state_file_is_ignored(isolated, tmp_path):
    net = load_network()
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    publish("socketcand://127.0.0.1:1/telethermo", "telethermo-hub", pid=dead.pid)
    assert running() is None and resolve_bus(net).settings.describe() == "virtual:telethermo"
    state_file().write_text("{not json")
    assert running() is None and resolve_bus(net).source == str(net.path)
    publish("socketcand://127.0.0.1:2/telethermo", "telethermo session")  # this process: alive
    assert resolve_bus(net).settings.describe() == "socketcand://127.0.0.1:2/telethermo"
    assert resolve_bus(net, use_published=False).settings.describe() == "virtual:telethermo"


def test_a_malformed_canrc_is_named_without_a_section_it_does_not_have(isolated, cli):
    """Issue 25: a damaged ~/.canrc was reported as "[telethermo] of ~/.canrc: cannot read", a section the
    file
    does not have (python-can reads the whole file with configparser before any section is looked up)."""
    canrc(isolated, "[default]\ninterface = virtual\nthis is not a key\n")
    code, out, err = cli("get", "master", "mode")
    assert code == 2 and out == ""
    assert err == (
        "telethermo get: error: ~/.canrc: not a valid python-can config file (INI sections such as "
        "[default] or [telethermo]): Source contains parsing errors: '/HOME/.canrc' [line 3]: "
        "'this is not a key\\n'\n".replace("/HOME", str(isolated))
    ), err
