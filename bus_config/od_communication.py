"""The communication objects (0x1000..0x1FFF, CiA 301 names) of both nodes' object dictionary, rendered
by :mod:`telethermo.bus_config.edsgen`: device and error objects, SYNC, store/restore, EMCY, heartbeats,
identity, and the PDOs between the two nodes."""

from __future__ import annotations

from telethermo.bus_config.od_types import (
    UNSIGNED8,
    UNSIGNED16,
    UNSIGNED32,
    VISIBLE_STRING,
    Obj,
    Var,
    _uint,
    array_obj,
)

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
        subs[i] = _uint(
            f"Application object {i}", UNSIGNED32, "rw", entries[i - 1] if i <= len(entries) else 0
        )
    return Obj(index, title, subs=subs, object_type=0x9)


def _mapping(index: int, sub: int, bits: int) -> int:
    return (index << 16) | (sub << 8) | bits


def _contact_pdo(contact: int, material: int, touches: int, beta: int, identification: bool) -> list[int]:
    """The contact PDO's mapping: the flag, slave -> master also its identification (code, touches, beta:
    8 bytes)."""
    extra = (
        [_mapping(material, 0, 8), _mapping(touches, 0, 16), _mapping(beta, 0, 32)] if identification else []
    )
    return [_mapping(contact, 0, 8)] + extra


def _ident_pdo(T_object0: int, early: int, stage: int) -> list[int]:
    """The slave's TPDO6 / the master's RPDO3: the object temperature (32 bits), the first answer's code and
    which answer identified_material holds (8 bits each: 6 bytes)."""
    return [_mapping(T_object0, 0, 32), _mapping(early, 0, 8), _mapping(stage, 0, 8)]


def _store_restore(index: int, title: str, signature: str) -> Obj:
    """0x1010 / 0x1011 (CiA 301): sub 1 all, 2 communication, 3 application parameters; each reads 1 (the
    node saves on command, telethermo.device.storage) and takes the signature written as ASCII."""
    what = {1: "all parameters", 2: "communication parameters", 3: "application parameters"}
    names = (
        {1: "Save all parameters", 2: "Save communication parameters", 3: "Save application parameters"}
        if signature == "save"
        else {
            1: "Restore all default parameters",
            2: "Restore communication default parameters",
            3: "Restore application default parameters",
        }
    )
    return array_obj(
        index,
        title,
        [
            _uint(
                names[i],
                UNSIGNED32,
                "rw",
                1,
                description=f"{what[i]}: reads 1 (saved on command), write '{signature}' "
                f"(0x{int.from_bytes(signature.encode(), 'little'):08X}), "
                "else abort 0x08000020",
            )
            for i in (1, 2, 3)
        ],
    )


def communication_objects(role: str) -> list[Obj]:
    """0x1000..0x1FFF for ``role`` (master: node 1, SYNC producer; slave: node 2)."""
    own, peer = NODE_IDS[role], NODE_IDS["slave" if role == "master" else "master"]
    return [
        *_device_objects(role),
        *_emcy_heartbeat_identity_objects(own, peer),
        *_rpdo_objects(role, peer),
        *_tpdo_objects(role),
    ]


def _V(idx: int, var: Var) -> Obj:
    return Obj(idx, var.name, var=var)


# The builders of 0x1000..0x1019, shared with the I/O module's dictionary (bus_config/io_eds.py): each takes
# what differs between the devices (values and their one line of documentation).


def device_type(value: int, doc: str) -> Obj:
    """0x1000: the device profile number (low word) and its additional information (high word)."""
    return _V(0x1000, _uint("Device type", UNSIGNED32, "ro", value, description=doc))


def error_objects(clear_doc: str) -> list[Obj]:
    """0x1001 error register (PDO-mappable) and 0x1003 the history of 8 errors; ``clear_doc`` says what a
    write of sub 0 (the number of errors) does."""
    return [
        _V(0x1001, _uint("Error register", UNSIGNED8, "ro", 0, pdo=True)),
        Obj(
            0x1003,
            "Pre-defined error field",
            object_type=0x8,
            subs={
                0: _uint("Number of errors", UNSIGNED8, "rw", 0, description=clear_doc),
                **{i: _uint(f"Standard error field {i}", UNSIGNED32, "ro", 0) for i in range(1, 9)},
            },
        ),
    ]


def sync_objects(cob_id: int, cob_id_doc: str, period_doc: str) -> list[Obj]:
    """0x1005 COB-ID SYNC (bit 30 set: the device produces SYNC) and 0x1006 the communication cycle period
    (us, default 10000 us)."""
    return [
        _V(0x1005, _uint("COB-ID SYNC", UNSIGNED32, "rw", cob_id, description=cob_id_doc)),
        _V(
            0x1006,
            _uint(
                "Communication cycle period", UNSIGNED32, "rw", 10000, 0, 10_000_000, description=period_doc
            ),
        ),
    ]


def name_objects(device_name: str) -> list[Obj]:
    """0x1008..0x100A: the device name, hardware version ("sim") and software version."""
    return [
        _V(0x1008, Var("Manufacturer device name", VISIBLE_STRING, "const", device_name)),
        _V(0x1009, Var("Manufacturer hardware version", VISIBLE_STRING, "const", "sim")),
        _V(0x100A, Var("Manufacturer software version", VISIBLE_STRING, "const", "0.1.0")),
    ]


def emcy_heartbeat_identity_objects(
    consumers: list[tuple[int, str]], product_code: int, sync_overflow: int
) -> list[Obj]:
    """0x1014..0x1019: EMCY (COB-ID, inhibit time in 100 us units), the consumer heartbeat entries
    (``consumers``: default and documentation of each; bits 16-23 node-ID, bits 0-15 time in ms), the
    producer heartbeat (100 ms), identity (``product_code``) and the SYNC counter overflow value."""
    return [
        _V(0x1014, _uint("COB-ID EMCY", UNSIGNED32, "ro", "$NODEID+0x80")),
        _V(0x1015, _uint("Inhibit time EMCY", UNSIGNED16, "rw", 10, 0, 0xFFFF, description="100 us units")),
        array_obj(
            0x1016,
            "Consumer heartbeat time",
            [
                _uint(f"Consumer heartbeat time {i}", UNSIGNED32, "rw", default, description=doc)
                for i, (default, doc) in enumerate(consumers, 1)
            ],
        ),
        _V(0x1017, _uint("Producer heartbeat time", UNSIGNED16, "rw", 100, 0, 0xFFFF, description="ms")),
        Obj(
            0x1018,
            "Identity object",
            object_type=0x9,
            subs={
                0: _uint("Highest sub-index supported", UNSIGNED8, "const", 4),
                1: _uint("Vendor-ID", UNSIGNED32, "ro", 0, description="no CiA vendor-ID assigned"),
                2: _uint("Product code", UNSIGNED32, "ro", product_code),
                3: _uint("Revision number", UNSIGNED32, "ro", 0x00010000),
                4: _uint("Serial number", UNSIGNED32, "ro", 0),
            },
        ),
        _V(
            0x1019,
            _uint(
                "Synchronous counter overflow value",
                UNSIGNED8,
                "rw",
                sync_overflow,
                0,
                240,
                description="0 no counter, 2..240 counter wraps after this value",
            ),
        ),
    ]


def _device_objects(role: str) -> list[Obj]:
    """0x1000..0x1011: device type, error register and history, SYNC, names and versions, store/restore."""
    return [
        device_type(0, "no device profile"),
        *error_objects("write 0 to clear the history (other values: abort 0x06090030)"),
        *sync_objects(
            0x40000080 if role == "master" else 0x80, "bit 30 set: this node produces SYNC", period_doc="us"
        ),
        *name_objects(f"telethermo {role}"),
        _store_restore(0x1010, "Store parameters", "save"),
        _store_restore(0x1011, "Restore default parameters", "load"),
    ]


def _emcy_heartbeat_identity_objects(own: int, peer: int) -> list[Obj]:
    """0x1014..0x1019 of a node: it watches the peer's heartbeat (250 ms), its product code is its node-ID
    and its SYNC counter overflows at 240."""
    consumers = [
        ((peer << 16) | 250, "the peer: bits 16-23 node-ID, bits 0-15 time in ms"),
        (0, "spare (0: unused): bits 16-23 node-ID, bits 0-15 time in ms"),
    ]
    return emcy_heartbeat_identity_objects(consumers, product_code=own, sync_overflow=240)


def _rpdo_objects(role: str, peer: int) -> list[Obj]:
    """0x1400..0x1602: the RPDOs from the peer (the master also receives the slave's identification)."""
    return [
        _pdo_comm(0x1400, "RPDO1 communication parameter", f"0x{0x180 + peer:X}", 1, tpdo=False),
        _pdo_map(0x1600, "RPDO1 mapping parameter", [_mapping(0x2103, 0, 32), _mapping(0x2104, 0, 32)]),
        _pdo_comm(0x1401, "RPDO2 communication parameter", f"0x{CONTACT_PDO_BASE + peer:X}", 1, tpdo=False),
        _pdo_map(
            0x1601, "RPDO2 mapping parameter", _contact_pdo(0x2105, 0x2615, 0x2616, 0x2617, role == "master")
        ),
        *(
            [
                _pdo_comm(
                    0x1402, "RPDO3 communication parameter", f"0x{IDENT_PDO_BASE + peer:X}", 255, tpdo=False
                ),
                _pdo_map(0x1602, "RPDO3 mapping parameter", _ident_pdo(0x261B, 0x261F, 0x2620)),
            ]
            if role == "master"
            else []
        ),
    ]


def _tpdo_objects(role: str) -> list[Obj]:
    """0x1800..0x1A05: the TPDOs (the slave also sends its identification)."""
    return [
        _pdo_comm(0x1800, "TPDO1 communication parameter", "$NODEID+0x180", 1, tpdo=True),
        _pdo_comm(
            0x1801, "TPDO2 communication parameter", "$NODEID+0x280", TPDO_STATUS_TRANSMISSION_TYPE, tpdo=True
        ),
        _pdo_comm(
            0x1802, "TPDO3 communication parameter", "$NODEID+0x380", TPDO_STATUS_TRANSMISSION_TYPE, tpdo=True
        ),
        _pdo_comm(
            0x1803, "TPDO4 communication parameter", "$NODEID+0x480", TPDO_STATUS_TRANSMISSION_TYPE, tpdo=True
        ),
        _pdo_comm(0x1804, "TPDO5 communication parameter", f"$NODEID+0x{CONTACT_PDO_BASE:X}", 1, tpdo=True),
        *(
            [
                _pdo_comm(
                    0x1805,
                    "TPDO6 communication parameter",
                    f"$NODEID+0x{IDENT_PDO_BASE:X}",
                    TPDO_STATUS_TRANSMISSION_TYPE,
                    tpdo=True,
                )
            ]
            if role == "slave"
            else []
        ),
        _pdo_map(0x1A00, "TPDO1 mapping parameter", [_mapping(0x2100, 0, 32), _mapping(0x2001, 0, 32)]),
        _pdo_map(0x1A01, "TPDO2 mapping parameter", [_mapping(0x2000, 0, 32), _mapping(0x2002, 0, 32)]),
        _pdo_map(0x1A02, "TPDO3 mapping parameter", [_mapping(0x2101, 0, 32), _mapping(0x2102, 0, 32)]),
        _pdo_map(
            0x1A03,
            "TPDO4 mapping parameter",
            [
                _mapping(0x2702, 0, 32),
                _mapping(0x2700, 0, 8),
                _mapping(0x2500, 0, 8),
                _mapping(0x2004, 0, 8),
                _mapping(0x2705, 0, 8),
            ],
        ),
        _pdo_map(
            0x1A04, "TPDO5 mapping parameter", _contact_pdo(0x2006, 0x2610, 0x2614, 0x2611, role == "slave")
        ),
        *(
            [_pdo_map(0x1A05, "TPDO6 mapping parameter", _ident_pdo(0x261A, 0x261C, 0x261E))]
            if role == "slave"
            else []
        ),
    ]
