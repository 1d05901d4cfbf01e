"""network.toml: the shipped file loads and matches the EDS defaults; every bad field is refused with
the file, the field and the expectation."""

from __future__ import annotations

import pytest

from telethermo.bus_config import path
from telethermo.device import NetworkConfigError, load_network

SHIPPED = path("network.toml").read_text()


def test_shipped_file_loads_and_agrees_with_the_design():
    cfg = load_network()
    assert (cfg.node("master").node_id, cfg.node("slave").node_id) == (1, 2)
    assert cfg.bus.bitrate == 1_000_000 and cfg.sync.period_s == 0.010 and cfg.sync.producer == "master"
    assert (cfg.heartbeat.producer_ms, cfg.heartbeat.consumer_ms) == (100, 250)
    assert cfg.node("master").eds == path("master.eds")
    s = cfg.device_settings("slave")
    assert (
        s.heartbeat_consumers == ((1, 250),) and s.sync_producer is False and s.rpdo_cob_ids == (0x181, 0x681)
    )
    assert cfg.device_settings("master").sync_producer is True
    assert cfg.bus.can_kwargs() == {"interface": "virtual", "channel": "telethermo", "bitrate": 1_000_000}


@pytest.mark.parametrize(
    "old, new, message",
    [
        (
            "period_s = 0.010",
            'period_s = "fast"',
            r"\[sync\] period_s: expected a number in \[0.0001, 1\] s, got 'fast'",
        ),
        ("period_s = 0.010", "period_s = 0.0", r"\[sync\] period_s: expected a number"),
        (
            "counter_overflow = 240",
            "counter_overflow = 1",
            r"\[sync\] counter_overflow: expected 0 \(no counter\) or an integer in \[2, 240\], got 1",
        ),
        (
            'producer = "master"',
            'producer = "both"',
            r"\[sync\] producer: expected one of master, slave, none, got 'both'",
        ),
        (
            "consumer_ms = 250",
            "consumer_ms = 80",
            r"\[heartbeat\] consumer_ms: expected an integer > producer_ms \(100\)",
        ),
        (
            "node_id = 2",
            "node_id = 1",
            r"\[nodes.slave\] node_id: expected a node-ID different from the master's \(1\), got 1",
        ),
        (
            "node_id = 2",
            "node_id = 200",
            r"\[nodes.slave\] node_id: expected an integer in \[1, 127\], got 200",
        ),
        ('eds = "slave.eds"', 'eds = "missing.eds"', r"\[nodes.slave\] eds: expected an existing EDS file"),
        (
            "bitrate = 1000000",
            "bitrate = true",
            r"\[bus\] bitrate: expected an integer in \[10000, 1000000\], got True",
        ),
        ("lockstep = true", 'lockstep = "yes"', r"\[sync\] lockstep: expected true or false, got 'yes'"),
        (
            "lockstep = true",
            "lockstep = true\nlock_step = true",
            r"\[sync\] lock_step: expected one of counter_overflow, .* \(an unknown key\)",
        ),
        ("[heartbeat]", "[heartbeat\n", r"network.toml: line \d+: not valid TOML"),
    ],
)
def test_bad_field_is_refused_with_file_field_and_expectation(tmp_path, old, new, message):
    assert old in SHIPPED
    bad = tmp_path / "network.toml"
    bad.write_text(SHIPPED.replace(old, new, 1))
    for role in ("master", "slave"):
        (tmp_path / f"{role}.eds").write_text(path(f"{role}.eds").read_text())
    with pytest.raises(NetworkConfigError, match=message) as exc:
        load_network(bad)
    assert str(bad) in str(exc.value)


def test_missing_file(tmp_path):
    with pytest.raises(NetworkConfigError, match="no such file"):
        load_network(tmp_path / "nope.toml")


def test_node_ids_from_the_file_reach_the_device(lab, tmp_path):
    """Renumbered nodes: RPDO1..3 follow the peer's TPDO1, TPDO5, TPDO6, the consumer watches the peer."""
    text = SHIPPED.replace("node_id = 1", "node_id = 11").replace("node_id = 2", "node_id = 12")
    (tmp_path / "network.toml").write_text(text)
    for role in ("master", "slave"):
        (tmp_path / f"{role}.eds").write_text(path(f"{role}.eds").read_text())
    cfg = load_network(tmp_path / "network.toml")
    dev = lab.device("master", node_id=11, settings=cfg.device_settings("master"))
    assert dev.read("RPDO1 communication parameter.COB-ID used by RPDO") == 0x180 + 12
    assert dev.read("RPDO2 communication parameter.COB-ID used by RPDO") == 0x680 + 12  # the contact PDO
    assert dev.read("RPDO3 communication parameter.COB-ID used by RPDO") == 0x6C0 + 12  # the identified T_o0
    assert dev.read("Consumer heartbeat time.Consumer heartbeat time 1") == (12 << 16) | 250
    assert dev.read("TPDO1 communication parameter.COB-ID used by TPDO") == 0x180 + 11
    assert dev.is_sync_producer
