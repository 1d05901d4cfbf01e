"""The object dictionary of both nodes, written once, rendered to CiA 306 EDS text.

``bus_config/master.eds`` and ``bus_config/slave.eds`` are generated from the tables below (and
checked in: they are the contract other tools read). Regenerate after editing this file::

    python -m telethermo.bus_config.edsgen          # rewrites master.eds and slave.eds (atomically) and,
                                                    # in a checkout, docs/parameters.md and the table of
                                                    # docs/canopen.md
    python -m telethermo.bus_config.edsgen --check  # exit 1 if one of them differs

Naming convention (the operator CLI ``get``/``set`` and the bus monitor rely on it):

- Communication objects (0x1000..0x1FFF) keep their CiA 301 names.
- Manufacturer objects (0x2000..) have snake_case names that end in their unit:
  ``_C`` °C, ``_W`` W, ``_A`` A, ``_N`` N, ``_s`` s, ``_C_per_s`` °C/s, ``_A_per_C`` A/°C,
  ``_A_per_C_s`` A/(°C·s), ``_A_per_W`` A/W, ``_C_per_W`` °C/W; no suffix = dimensionless
  (count, code, flag, model order). The same unit is in the non-standard ``Unit=`` key (ASCII:
  ``degC``, ``W``, ...), which canopen reads into ``ODVariable.unit``.
- Every writable manufacturer object has ``LowLimit``/``HighLimit``. REAL32 limits are written as
  decimals (canopen's parser drops them; telethermo.device.eds_info re-reads them).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from telethermo.atomic import write_text_atomic
from telethermo.bus_config import path as _path
from telethermo.bus_config import partable
from telethermo.bus_config.od_manufacturer import manufacturer_objects
from telethermo.bus_config.od_types import (  # noqa: F401 (UNIT_TEXT: the tests read it here too)
    BOOLEAN, INTEGER16, REAL32, REAL64, UNIT_TEXT, UNSIGNED8, UNSIGNED16, UNSIGNED32, VISIBLE_STRING, Obj, Var, _uint,
)

# CiA 306 [FileInfo] dates (mm-dd-yyyy, hh:mm(AM|PM)): of the object dictionary's last change, set by hand
# (the files are generated, so they must not change with the clock)
EDS_DATE, EDS_TIME = "11-23-2026", "10:00PM"


NODE_IDS = {"master": 1, "slave": 2}
#: TPDO5 (the contact flag, 1 byte, every SYNC) goes on 0x680 + node-ID: outside CiA 301's predefined
#: connection set and its restricted COB-IDs (0x680..0x6DF are free), so no other device's default uses it.
#: It is sent after TPDO1 in the same SYNC, so a peer that has it has the TPDO1 of the same cycle too.
CONTACT_PDO_BASE = 0x680
#: the slave's TPDO6 (identified object temperature, first answer and stage, every 10th SYNC) on 0x6C0 +
#: node-ID (free range); the master's RPDO3 takes it event-driven (type 255), so the lockstep producer (waits
#: for the last synchronous RPDO) does not
IDENT_PDO_BASE = 0x6C0
TPDO_STATUS_TRANSMISSION_TYPE = 10  # status TPDOs 2..4 go with every 10th SYNC (bus load at 1 kHz)


def _pdo_comm(index: int, title: str, cob_id: str, trans_type: int, tpdo: bool) -> Obj:
    subs = {
        0: _uint("Highest sub-index supported", UNSIGNED8, "const", 6 if tpdo else 5),
        1: _uint(f"COB-ID used by {'TPDO' if tpdo else 'RPDO'}", UNSIGNED32, "rw", cob_id),
        2: _uint("Transmission type", UNSIGNED8, "rw", trans_type),
    }
    if tpdo:
        subs[3] = _uint("Inhibit time", UNSIGNED16, "rw", 0, description="100 us units")
    subs[5] = _uint("Event timer", UNSIGNED16, "rw", 0, description="ms, 0: off")
    if tpdo:
        subs[6] = _uint("SYNC start value", UNSIGNED8, "rw", 0, 0, 240)
    return Obj(index, title, subs=subs, object_type=0x9)


def _pdo_map(index: int, title: str, entries: list[int]) -> Obj:
    subs = {0: _uint("Number of mapped application objects in PDO", UNSIGNED8, "rw", len(entries), 0, 8)}
    for i in range(1, 9):
        subs[i] = _uint(f"Application object {i}", UNSIGNED32, "rw", entries[i - 1] if i <= len(entries) else 0)
    return Obj(index, title, subs=subs, object_type=0x9)


def _mapping(index: int, sub: int, bits: int) -> int:
    return (index << 16) | (sub << 8) | bits


def _contact_pdo(contact: int, material: int, touches: int, beta: int, identification: bool) -> list[int]:
    """The contact PDO's mapping: the flag, slave -> master also its identification (code, touches, beta: 8 bytes)."""
    extra = [_mapping(material, 0, 8), _mapping(touches, 0, 16), _mapping(beta, 0, 32)] if identification else []
    return [_mapping(contact, 0, 8)] + extra


def _ident_pdo(T_object0: int, early: int, stage: int) -> list[int]:
    """The slave's TPDO6 / the master's RPDO3: the object temperature (32 bits), the first answer's code and
    which answer identified_material holds (8 bits each: 6 bytes)."""
    return [_mapping(T_object0, 0, 32), _mapping(early, 0, 8), _mapping(stage, 0, 8)]


def _store_restore(index: int, title: str, signature: str) -> Obj:
    """0x1010 / 0x1011 (CiA 301): sub 1 all, 2 communication, 3 application parameters; each reads 1 (the
    node saves on command, telethermo.device.storage) and takes the signature written as ASCII."""
    what = {1: "all parameters", 2: "communication parameters", 3: "application parameters"}
    names = ({1: "Save all parameters", 2: "Save communication parameters", 3: "Save application parameters"}
             if signature == "save" else
             {1: "Restore all default parameters", 2: "Restore communication default parameters",
              3: "Restore application default parameters"})
    return Obj(index, title, object_type=0x8, subs={
        0: _uint("Highest sub-index supported", UNSIGNED8, "const", 3),
        **{i: _uint(names[i], UNSIGNED32, "rw", 1,
                    description=f"{what[i]}: reads 1 (saved on command), write '{signature}' "
                                f"(0x{int.from_bytes(signature.encode(), 'little'):08X}), "
                                "else abort 0x08000020")
           for i in (1, 2, 3)}})


def communication_objects(role: str) -> list[Obj]:
    """0x1000..0x1FFF for ``role`` (master: node 1, SYNC producer; slave: node 2)."""
    own, peer = NODE_IDS[role], NODE_IDS["slave" if role == "master" else "master"]
    V = lambda idx, var: Obj(idx, var.name, var=var)  # noqa: E731
    objs = [
        V(0x1000, _uint("Device type", UNSIGNED32, "ro", 0, description="no device profile")),
        V(0x1001, _uint("Error register", UNSIGNED8, "ro", 0, pdo=True)),
        Obj(0x1003, "Pre-defined error field", object_type=0x8, subs={
            0: _uint("Number of errors", UNSIGNED8, "rw", 0, description="write 0 to clear the history (other values: abort 0x06090030)"),
            **{i: _uint(f"Standard error field {i}", UNSIGNED32, "ro", 0) for i in range(1, 9)}}),
        V(0x1005, _uint("COB-ID SYNC", UNSIGNED32, "rw", 0x40000080 if role == "master" else 0x80,
                        description="bit 30 set: this node produces SYNC")),
        V(0x1006, _uint("Communication cycle period", UNSIGNED32, "rw", 10000, 0, 10_000_000, description="us")),
        V(0x1008, Var("Manufacturer device name", VISIBLE_STRING, "const", f"telethermo {role}")),
        V(0x1009, Var("Manufacturer hardware version", VISIBLE_STRING, "const", "sim")),
        V(0x100A, Var("Manufacturer software version", VISIBLE_STRING, "const", "0.1.0")),
        _store_restore(0x1010, "Store parameters", "save"),
        _store_restore(0x1011, "Restore default parameters", "load"),
        V(0x1014, _uint("COB-ID EMCY", UNSIGNED32, "ro", "$NODEID+0x80")),
        V(0x1015, _uint("Inhibit time EMCY", UNSIGNED16, "rw", 10, 0, 0xFFFF, description="100 us units")),
        Obj(0x1016, "Consumer heartbeat time", object_type=0x8, subs={
            0: _uint("Highest sub-index supported", UNSIGNED8, "const", 2),
            1: _uint("Consumer heartbeat time 1", UNSIGNED32, "rw", (peer << 16) | 250,
                     description="the peer: bits 16-23 node-ID, bits 0-15 time in ms"),
            2: _uint("Consumer heartbeat time 2", UNSIGNED32, "rw", 0,
                     description="spare (0: unused): bits 16-23 node-ID, bits 0-15 time in ms")}),
        V(0x1017, _uint("Producer heartbeat time", UNSIGNED16, "rw", 100, 0, 0xFFFF, description="ms")),
        Obj(0x1018, "Identity object", object_type=0x9, subs={
            0: _uint("Highest sub-index supported", UNSIGNED8, "const", 4),
            1: _uint("Vendor-ID", UNSIGNED32, "ro", 0, description="no CiA vendor-ID assigned"),
            2: _uint("Product code", UNSIGNED32, "ro", own),
            3: _uint("Revision number", UNSIGNED32, "ro", 0x00010000),
            4: _uint("Serial number", UNSIGNED32, "ro", 0)}),
        V(0x1019, _uint("Synchronous counter overflow value", UNSIGNED8, "rw", 240, 0, 240,
                        description="0 no counter, 2..240 counter wraps after this value")),
        _pdo_comm(0x1400, "RPDO1 communication parameter", f"0x{0x180 + peer:X}", 1, tpdo=False),
        _pdo_map(0x1600, "RPDO1 mapping parameter", [_mapping(0x2103, 0, 32), _mapping(0x2104, 0, 32)]),
        _pdo_comm(0x1401, "RPDO2 communication parameter", f"0x{CONTACT_PDO_BASE + peer:X}", 1, tpdo=False),
        _pdo_map(0x1601, "RPDO2 mapping parameter", _contact_pdo(0x2105, 0x2615, 0x2616, 0x2617, role == "master")),
        *([_pdo_comm(0x1402, "RPDO3 communication parameter", f"0x{IDENT_PDO_BASE + peer:X}", 255, tpdo=False),
           _pdo_map(0x1602, "RPDO3 mapping parameter", _ident_pdo(0x261B, 0x261F, 0x2620))]
          if role == "master" else []),
        _pdo_comm(0x1800, "TPDO1 communication parameter", "$NODEID+0x180", 1, tpdo=True),
        _pdo_comm(0x1801, "TPDO2 communication parameter", "$NODEID+0x280", TPDO_STATUS_TRANSMISSION_TYPE, tpdo=True),
        _pdo_comm(0x1802, "TPDO3 communication parameter", "$NODEID+0x380", TPDO_STATUS_TRANSMISSION_TYPE, tpdo=True),
        _pdo_comm(0x1803, "TPDO4 communication parameter", "$NODEID+0x480", TPDO_STATUS_TRANSMISSION_TYPE, tpdo=True),
        _pdo_comm(0x1804, "TPDO5 communication parameter", f"$NODEID+0x{CONTACT_PDO_BASE:X}", 1, tpdo=True),
        *([_pdo_comm(0x1805, "TPDO6 communication parameter", f"$NODEID+0x{IDENT_PDO_BASE:X}",
                     TPDO_STATUS_TRANSMISSION_TYPE, tpdo=True)] if role == "slave" else []),
        _pdo_map(0x1A00, "TPDO1 mapping parameter", [_mapping(0x2100, 0, 32), _mapping(0x2001, 0, 32)]),
        _pdo_map(0x1A01, "TPDO2 mapping parameter", [_mapping(0x2000, 0, 32), _mapping(0x2002, 0, 32)]),
        _pdo_map(0x1A02, "TPDO3 mapping parameter", [_mapping(0x2101, 0, 32), _mapping(0x2102, 0, 32)]),
        _pdo_map(0x1A03, "TPDO4 mapping parameter", [_mapping(0x2702, 0, 32), _mapping(0x2700, 0, 8),
                                                     _mapping(0x2500, 0, 8), _mapping(0x2004, 0, 8),
                                                     _mapping(0x2705, 0, 8)]),
        _pdo_map(0x1A04, "TPDO5 mapping parameter", _contact_pdo(0x2006, 0x2610, 0x2614, 0x2611, role == "slave")),
        *([_pdo_map(0x1A05, "TPDO6 mapping parameter", _ident_pdo(0x261A, 0x261C, 0x261E))]
          if role == "slave" else []),
    ]
    return objs


def _check_value(section: str, text: str) -> None:
    """A value every EDS reader takes: no ';' (an inline comment for canopen's parser), no line break,
    no '=' (canopen-monitor splits every line on '=' and crashes on a second one)."""
    if any(c in text for c in ";=\n"):
        raise ValueError(f"[{section}]: ';', '=' or a line break in {text!r} would break EDS readers")


def _var_lines(section: str, var: Var) -> list[str]:
    for text in (var.name, var.description, var.default, var.unit, var.low or "", var.high or ""):
        _check_value(section, text)
    lines = [f"[{section}]", f"ParameterName={var.name}", "ObjectType=0x7", f"DataType=0x{var.data_type:04X}",
             f"AccessType={var.access}", f"DefaultValue={var.default}", f"PDOMapping={int(var.pdo)}"]
    if var.low is not None:
        lines.append(f"LowLimit={var.low}")
    if var.high is not None:
        lines.append(f"HighLimit={var.high}")
    if var.unit:
        lines.append(f"Unit={var.unit}")
    if var.description:
        lines.append(f"Description={var.description}")
    return lines + [""]


def render(role: str) -> str:
    """The EDS text of ``role`` ("master" or "slave")."""
    if role not in NODE_IDS:
        raise ValueError(f"role must be one of {sorted(NODE_IDS)}, got {role!r}")
    comm, manu = communication_objects(role), manufacturer_objects(role)
    mandatory = [o for o in comm if o.index in (0x1000, 0x1001, 0x1018)]
    optional = [o for o in comm if o not in mandatory]
    n_rx = sum(1 for o in comm if 0x1400 <= o.index <= 0x15FF)
    n_tx = sum(1 for o in comm if 0x1800 <= o.index <= 0x19FF)
    out = [
        "[FileInfo]", f"FileName={role}.eds", "FileVersion=1", "FileRevision=0", "EDSVersion=4.0",
        f"Description=telethermo {role} node (bilateral thermal telepresence), generated by bus_config/edsgen.py",
        f"CreationTime={EDS_TIME}", f"CreationDate={EDS_DATE}", "CreatedBy=telethermo",
        f"ModificationTime={EDS_TIME}", f"ModificationDate={EDS_DATE}", "ModifiedBy=telethermo", "",
        "[DeviceInfo]", "VendorName=telethermo", "VendorNumber=0x00000000", f"ProductName=telethermo {role}",
        f"ProductNumber=0x{NODE_IDS[role]:08X}", "RevisionNumber=0x00010000", f"OrderCode=telethermo-{role}",
        *[f"BaudRate_{r}={int(r == 1000 or r == 500 or r == 250 or r == 125)}" for r in (10, 20, 50, 125, 250, 500, 800, 1000)],
        "SimpleBootUpMaster=0", "SimpleBootUpSlave=1", "Granularity=8", "DynamicChannelsSupported=0",
        "GroupMessaging=0", f"NrOfRXPDO={n_rx}", f"NrOfTXPDO={n_tx}", "LSS_Supported=0", "",
        "[DummyUsage]", *[f"Dummy{i:04d}=0" for i in range(1, 8)], "",
        "[Comments]", "Lines=2", "Line1=Manufacturer object names end in their unit (_C degC, _W, _A, _s, ...).",
        "Line2=REAL32 LowLimit/HighLimit are decimals, SDO writes outside them abort 0x06090030/31/32.", "",
    ]
    for title, objs in (("MandatoryObjects", mandatory), ("OptionalObjects", optional), ("ManufacturerObjects", manu)):
        out += [f"[{title}]", f"SupportedObjects={len(objs)}"]
        out += [f"{i}=0x{o.index:04X}" for i, o in enumerate(objs, 1)] + [""]
    for o in comm + manu:
        if o.var is not None:
            out += _var_lines(f"{o.index:04X}", o.var)
            continue
        out += [f"[{o.index:04X}]", f"ParameterName={o.name}", f"ObjectType=0x{o.object_type:X}",
                f"SubNumber=0x{len(o.subs):X}", ""]
        for sub, var in o.subs.items():
            out += _var_lines(f"{o.index:04X}sub{sub:X}", var)
    for line in out:   # every value of every section, the file's own keys included
        if "=" in line:
            _check_value(role, line.split("=", 1)[1])
    return "\n".join(out)


def markdown_table(role: str = "master") -> str:
    """The object dictionary as a Markdown table (for docs/canopen.md)."""
    types = {BOOLEAN: "BOOLEAN", UNSIGNED8: "U8", UNSIGNED16: "U16", UNSIGNED32: "U32", REAL32: "REAL32", REAL64: "REAL64",
             VISIBLE_STRING: "STRING", INTEGER16: "I16"}
    rows = ["| index | sub | name | type | access | default | range | unit | PDO |",
            "|---|---|---|---|---|---|---|---|---|"]

    def row(index, sub, var):
        rng = f"{var.low} .. {var.high}" if var.low is not None else ""
        rows.append(f"| 0x{index:04X} | {sub} | {var.name} | {types.get(var.data_type, hex(var.data_type))} | "
                    f"{var.access} | {var.default} | {rng} | {var.unit} | {'yes' if var.pdo else ''} |")

    for o in communication_objects(role) + manufacturer_objects(role):
        if o.var is not None:
            row(o.index, 0, o.var)
        elif o.index in (0x2310, 0x2311):
            first, last = o.subs[1], o.subs[len(o.subs) - 1]
            rows.append(f"| 0x{o.index:04X} | 1..{len(o.subs) - 1} | {o.name}: {first.name}..{last.name} | {types[first.data_type]} | "
                        f"{first.access} | {first.default} | {first.low} .. {first.high} | | |")
        else:
            for sub, var in o.subs.items():
                row(o.index, sub, var)
    return "\n".join(rows)


CANOPEN_DOC = partable.DOC.with_name("canopen.md")
TABLE_HEAD = "| index | sub | name | type | access | default | range | unit | PDO |"


def docs() -> dict[Path, str]:
    """The generated docs pages of a checkout (none when the docs are not there): path -> text."""
    if not CANOPEN_DOC.exists():
        return {}
    lines = CANOPEN_DOC.read_text(encoding="utf-8").split("\n")
    start = lines.index(TABLE_HEAD)
    end = next((i for i in range(start, len(lines)) if not lines[i].startswith("|")), len(lines))
    canopen_doc = "\n".join(lines[:start] + [markdown_table("master")] + lines[end:])
    return {partable.DOC: partable.markdown(), CANOPEN_DOC: canopen_doc}


def main(argv: list[str] | None = None) -> int:

    parser = argparse.ArgumentParser(description="Generate bus_config/master.eds and slave.eds.")
    parser.add_argument("--check", action="store_true", help="only compare; exit 1 if a file differs")
    parser.add_argument("--table", metavar="ROLE", help="print the object dictionary of ROLE as Markdown")
    args = parser.parse_args(argv)
    if args.table:
        print(markdown_table(args.table))
        return 0
    stale = []
    outputs = {Path(_path(f"{role}.eds")): render(role) for role in NODE_IDS}
    for target, text in [*outputs.items(), *docs().items()]:
        if args.check:
            if not target.exists() or target.read_text(encoding="utf-8") != text:
                stale.append(str(target))
        else:
            write_text_atomic(target, text)
    if stale:
        print("stale (run python -m telethermo.bus_config.edsgen): " + ", ".join(stale), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
