"""The object dictionary of the simulated CiA 401 I/O module (``telethermo-iomodule``), rendered to
``bus_config/io_module.eds`` (checked in, as master.eds and slave.eds). Regenerate after editing::

    python -m telethermo.bus_config.io_eds          # rewrites io_module.eds (atomically)
    python -m telethermo.bus_config.io_eds --check  # exit 1 if the checked-in file differs

What a lab's generic analog I/O module offers (docs/hardware.md, reference/canopen-io-modules.md):

- 0x6401:1..6 analog inputs, INTEGER16 counts of a 16-bit ADC (±10 V = ±32768 counts), read-only,
  TPDO-mappable: TPDO1 = channels 1..4, TPDO2 = channels 5, 6 and the output actually applied (0x2101),
  both transmission type 1 (every SYNC).
- 0x6411:1 analog output (the TEM current amplifier's input), INTEGER16 counts of a 16-bit DAC, RPDO1
  (type 255: applied on receipt).
- 0x6443:1 output error mode (0 keep the last value, 1 go to 0x6444) and 0x6444:1 substitute value
  (INTEGER32, as the public DS401 example EDS): the output's state on a communication error or when the
  module leaves OPERATIONAL. **The defaults are the trap of the example EDS: 0 (hold).** Commissioning
  sets 1 and the counts of 0 A.
- 0x1029:1 error behaviour on a communication error (0 pre-operational, 1 no change, 2 stopped).
- 0x1016:1..2 consumer heartbeat (0: not watching; commissioning watches the controller).
- 0x2100 ADC sampling period, ms (default 400 ms: the 2.5 Hz default of real modules; a 100 Hz loop
  must set it).
- 0x2101 output actual (the DAC counts applied now), 0x2102 output in its error state (0/1).
- 0x2110 simulated wiring fault: bit n-1 set = input n open circuit (reads 0x7FFF, EMCY 0xFF10).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from telethermo.atomic import write_text_atomic
from telethermo.bus_config import path as _path
from telethermo.bus_config.edsgen import eds_header, pdo_counts, render_eds
from telethermo.bus_config.od_communication import (
    _V,
    _mapping,
    _pdo_comm,
    _pdo_map,
    device_type,
    emcy_heartbeat_identity_objects,
    error_objects,
    name_objects,
    sync_objects,
)
from telethermo.bus_config.od_types import (
    INTEGER16,
    INTEGER32,
    UNSIGNED8,
    UNSIGNED16,
    Obj,
    Var,
    _uint,
    array_obj,
)

FILE_NAME = "io_module.eds"
#: the node-ID the file's $NODEID examples are checked with (the program takes any 1..127)
DEFAULT_NODE_ID = 3
#: analog input channels (0x6401:1..N), in the order the simulated rig side wires them (docs/hardware.md)
N_INPUTS = 6
#: CiA 301 0x1000: profile 401 (low word 0x0191), additional information AI (0x04) and AO (0x08)
DEVICE_TYPE = (0x04 | 0x08) << 16 | 0x0191
SAMPLING_INDEX, OUTPUT_ACTUAL_INDEX, OUTPUT_ERROR_INDEX, OPEN_CIRCUIT_INDEX = 0x2100, 0x2101, 0x2102, 0x2110


def _int(
    name: str,
    data_type: int,
    access: str,
    default: int,
    low: int | None = None,
    high: int | None = None,
    pdo: bool = False,
    description: str = "",
) -> Var:
    """A signed integer entry (decimal text: CiA 306 allows either)."""
    return Var(
        name,
        data_type,
        access,
        str(default),
        None if low is None else str(low),
        None if high is None else str(high),
        pdo,
        description,
    )


def communication_objects() -> list[Obj]:
    """0x1000..0x1FFF of the I/O module: the nodes' builders (bus_config/od_communication.py) with the
    module's values, no store/restore, 0x1029 error behaviour, its PDOs."""
    heartbeat_doc = "bits 16-23 node-ID, bits 0-15 time in ms (0: unused)"
    error_behaviour = _uint(
        "Communication error",
        UNSIGNED8,
        "rw",
        0,
        0,
        2,
        description="0 pre-operational, 1 no change, 2 stopped",
    )
    return [
        device_type(DEVICE_TYPE, "CiA 401 analog inputs and outputs"),
        *error_objects("write 0 to clear the history"),
        *sync_objects(0x80, "consumes SYNC", "us: the simulated plant advances by this at every SYNC"),
        *name_objects("telethermo io module (simulated)"),
        *emcy_heartbeat_identity_objects([(0, heartbeat_doc)] * 2, product_code=0x0401, sync_overflow=0),
        array_obj(0x1029, "Error behaviour", [error_behaviour], sub0_access="ro"),
        *_pdo_objects(),
    ]


def _pdo_objects() -> list[Obj]:
    """0x1400..0x1A01: the drive RPDO and the two input TPDOs."""
    return [
        _pdo_comm(0x1400, "RPDO1 communication parameter", "$NODEID+0x200", 255, tpdo=False),
        _pdo_map(0x1600, "RPDO1 mapping parameter", [_mapping(0x6411, 1, 16)]),
        _pdo_comm(0x1800, "TPDO1 communication parameter", "$NODEID+0x180", 1, tpdo=True),
        _pdo_comm(0x1801, "TPDO2 communication parameter", "$NODEID+0x280", 1, tpdo=True),
        _pdo_map(0x1A00, "TPDO1 mapping parameter", [_mapping(0x6401, s, 16) for s in (1, 2, 3, 4)]),
        _pdo_map(
            0x1A01,
            "TPDO2 mapping parameter",
            [_mapping(0x6401, 5, 16), _mapping(0x6401, 6, 16), _mapping(OUTPUT_ACTUAL_INDEX, 0, 16)],
        ),
    ]


def profile_objects() -> list[Obj]:
    """The CiA 401 objects 0x6000..: analog inputs and outputs, output error mode and substitute value."""
    return [
        array_obj(
            0x6401,
            "Read analog input 16-bit",
            [
                _int(f"Analog input {i}", INTEGER16, "ro", 0, pdo=True, description="ADC counts")
                for i in range(1, N_INPUTS + 1)
            ],
        ),
        array_obj(
            0x6411,
            "Write analog output 16-bit",
            [_int("Analog output 1", INTEGER16, "rw", 0, -32768, 32767, pdo=True, description="DAC counts")],
        ),
        array_obj(
            0x6443,
            "Analog output error mode",
            [
                _uint(
                    "Error mode output 1",
                    UNSIGNED8,
                    "rw",
                    0,
                    0,
                    1,
                    description="0 keep the last value (the example EDS default), "
                    "1 go to the substitute value",
                )
            ],
        ),
        array_obj(
            0x6444,
            "Analog output error value integer",
            [_int("Error value output 1", INTEGER32, "rw", 0, -32768, 32767, description="DAC counts")],
        ),
    ]


def manufacturer_objects() -> list[Obj]:
    return [
        _V(
            SAMPLING_INDEX,
            _uint(
                "adc_sampling_period_ms",
                UNSIGNED16,
                "rw",
                400,
                1,
                1000,
                description="period of the ADC conversions of every input",
            ),
        ),
        _V(
            OUTPUT_ACTUAL_INDEX,
            _int(
                "output_actual",
                INTEGER16,
                "ro",
                0,
                pdo=True,
                description="DAC counts applied now (0x6411 or its error value)",
            ),
        ),
        _V(
            OUTPUT_ERROR_INDEX,
            _uint(
                "output_error_state",
                UNSIGNED8,
                "ro",
                0,
                description="1 while the output is in its error state",
            ),
        ),
        _V(
            OPEN_CIRCUIT_INDEX,
            _uint(
                "sim_open_circuit",
                UNSIGNED8,
                "rw",
                0,
                0,
                (1 << N_INPUTS) - 1,
                description="simulated wiring fault: bit n-1 set opens input n",
            ),
        ),
    ]


def render() -> str:
    """The EDS text of the I/O module."""
    comm = communication_objects() + profile_objects()
    header = eds_header(
        FILE_NAME,
        "telethermo simulated CiA 401 analog I/O module, generated by bus_config/io_eds.py",
        "telethermo io module",
        0x0401,
        "telethermo-iomodule",
        pdo_counts(comm),
        [
            "Analog counts: 16-bit, -32768..32767 is -10 V..+10 V (305.2 uV per count).",
            "0x6443/0x6444 default to hold (the DS401 example's trap): commissioning sets substitute 0 A.",
        ],
    )
    return render_eds(FILE_NAME, header, comm, manufacturer_objects())


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=f"Generate bus_config/{FILE_NAME}.")
    parser.add_argument("--check", action="store_true", help="only compare; exit 1 if the file differs")
    args = parser.parse_args(argv)
    target, text = Path(_path(FILE_NAME)), render()
    if args.check:
        if not target.exists() or target.read_text(encoding="ascii") != text:
            print(f"stale EDS (run python -m telethermo.bus_config.io_eds): {target}", file=sys.stderr)
            return 1
        return 0
    write_text_atomic(target, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
