"""How `get`/`set` show values: hex for COB-IDs and bit fields, names for enumerations, units always,
the node in every line; enumeration names accepted by `set`."""

from __future__ import annotations

import dataclasses


from telethermo.bus_config import edsgen
from telethermo.bus_config import path as cfg_path
from telethermo.device.eds_info import EdsInfo
from telethermo.remote import values
from telethermo.cli.main import EXIT_OK, EXIT_USAGE
from telethermo.cli.params import describe
from telethermo import units

EDS = EdsInfo(cfg_path("master.eds"))


def show(name, value):
    return values.fmt(value, EDS.get(name), EDS)


def test_cob_ids_and_bit_fields_in_hex_with_their_meaning():
    assert show("COB-ID SYNC", 0x40000080) == "0x40000080 (COB-ID 0x080, produces SYNC)"
    assert show("COB-ID SYNC", 0x80) == "0x00000080 (COB-ID 0x080, consumes SYNC)"
    assert show("0x1800:1", 0x80000181) == "0x80000181 (COB-ID 0x181, disabled)"
    assert show("0x1A00:1", 0x21000020) == "0x21000020 (0x2100:00 estimate_C, 32 bits)"
    assert show("0x1A00:2", 0) == "0x00000000 (unused)"
    assert show("0x1016:1", 0x000200FA) == "0x000200FA (node 2, 250 ms)"
    assert show("Error register", 0x19) == "0x19 (generic, temperature, communication)"
    assert show("active_trips", 0x280) == "0x0280 (heat_sink, peer_lost)"
    assert show("last_trip_code", 0x8130) == "0x8130 (Life guard error or heartbeat error)"
    assert show("last_trip_code", 0) == "0x0000 (none)"
    assert show("0x1003:1", 0x00014210) == "0x00014210 (EMCY 0x4210 Device temperature)"
    assert show("model_crc32", 0xDEADBEEF) == "0xDEADBEEF"
    assert show("Identity object.Vendor-ID", 5) == "0x00000005"
    # counts stay decimal, even when an unrelated word of the description is "bit"
    assert show("ident_hold_samples", 25) == "25"
    assert show("0x1A00:0", 2) == "2"
    assert show("Identity object.Highest sub-index supported", 4) == "4"


def test_enumerations_by_name():
    assert show("mode", 1) == "1 (telepresence)"
    assert show("safety_state", 2) == "2 (ramp_to_neutral)"
    assert show("estimator", 0) == "0 (model)"
    assert show("model_status", 2) == "2 (edited since loaded)"  # from the EDS description
    assert show("ident_state", 3) == "3 (interrupted)"
    assert show("mode", 9) == "9 (not a listed value)"
    assert values.parse_enum(EDS.get("mode"), "Telepresence") == 1
    assert values.parse_enum(EDS.get("safety_state"), "ramp to neutral") == 2
    assert values.parse_enum(EDS.get("kp_A_per_C"), "1") is None


def test_estimator_codes_are_the_nodes():
    from telethermo.nodes.odparams import ESTIMATOR_CODES

    names = values.enum_names(EDS.get("estimator"))
    assert names == {code: est.value for est, code in ESTIMATOR_CODES.items()}


def test_units_always():
    assert show("kp_A_per_C", 0.8) == "0.8 A/degC"
    assert show("Producer heartbeat time", 100) == "100 ms"
    assert show("Communication cycle period", 10000) == "10000 us"
    assert show("Inhibit time EMCY", 10) == "10 x100 us"
    # an EDS without Unit= keys (another vendor's, or an old one): the unit from the name's suffix
    bare = dataclasses.replace(EDS.get("ramp_limit_C_per_s"), unit="")
    assert values.fmt(2.5, bare) == "2.5 degC/s"
    # one naming rule: the unit table's, not a copy (telethermo/units.py)
    assert values.NAME_UNITS is units.SUFFIXES and edsgen.UNIT_TEXT == dict(units.SUFFIXES)


def test_get_names_the_node_on_every_line(nodes, cli):
    code, out, err = cli(
        "get", *nodes.bus, "slave", "COB-ID SYNC", "mode", "kp_A_per_C", "0x1018:1", "Producer heartbeat time"
    )
    assert code == EXIT_OK, err
    lines = out.splitlines()
    assert [ln.split(" = ")[0] for ln in lines] == [
        "slave 0x1005 COB-ID SYNC",
        "slave 0x2500 mode",
        "slave 0x2200 kp_A_per_C",
        "slave 0x1018:01 Identity object.Vendor-ID",
        "slave 0x1017 Producer heartbeat time",
    ]
    assert lines[0].split(" = ")[1].startswith("0x00000080 (COB-ID 0x080, consumes SYNC)")
    assert lines[1].split(" = ")[1].startswith("0 (idle)")
    assert lines[4].split(" = ")[1].startswith("100 ms")


def test_set_takes_enumeration_names(nodes, cli):
    code, out, err = cli("set", *nodes.bus, "master", "mode", "telepresence")
    assert code == EXIT_OK, err
    assert out.startswith("master 0x2500 mode = 1 (telepresence)")
    assert nodes.devices["master"].read("mode") == 1
    code, _, err = cli("set", *nodes.bus, "master", "mode", "telepresense")
    assert code == EXIT_USAGE and err.count("\n") == 1
    assert (
        "mode: expected one of idle (0), telepresence (1), render (2), identify (3), got 'telepresense'"
        in err
    )


def test_get_says_what_a_parameter_write_changes_from_the_parameter_table():
    """``get``/``set`` lines name an operator parameter's scope and an unstored one (bus_config/partable.py);
    a measurement has neither."""
    info = EdsInfo(cfg_path("master.eds"))
    assert describe(info.get("kp_A_per_C")) == "REAL32, rw, [0, 20] A/degC, per mode"
    assert describe(info.get("T_max_C")).endswith("degC, all modes")
    assert describe(info.get("mode")).endswith(", node, not stored")
    assert describe(info.get("ident_seed")).endswith(", IDENTIFY")
    assert describe(info.get("T_sensor_C")) == "REAL32, ro, no range"
