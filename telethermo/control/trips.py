"""Why the safety envelope intervened: the trips, their CiA 301 emergency codes and the error-register
(0x1001) bits they set, and which trips cut the current or concern the peer (DESIGN.md §6)."""

from __future__ import annotations

from collections.abc import Iterable
from enum import Enum, IntEnum

from telethermo.cia301 import EMCY_HEARTBEAT, EMCY_PEER_INVALID

# ---------------------------------------------------------------------------------------------
# trips, EMCY codes and error-register bits


class Trip(str, Enum):
    """Why the envelope intervened (latched until cleared)."""

    SENSOR_INVALID = "sensor_invalid"  # NaN/inf temperature, flux, sink or current reading
    OPEN_THERMOCOUPLE = "open_thermocouple"  # reading at the ADC rail (open circuit)
    SENSOR_RANGE = "sensor_range"  # implausible temperature or flux
    MODEL_MISMATCH = "model_mismatch"  # |T_sensor - T_pred| too large for too long
    SURFACE_HIGH = "surface_high"  # pad surface above T_max_C + margin
    SURFACE_LOW = "surface_low"  # pad surface below T_min_C - margin
    TIME_AT_TEMPERATURE = "time_at_temperature"  # too long above hot_C
    HEAT_SINK = "heat_sink"  # heat sink above sink_trip_C
    OVERCURRENT = "overcurrent"  # measured current above the hardware limit
    PEER_LOST = "peer_lost"  # heartbeat / PDO timeout reported by the node
    PEER_INVALID = "peer_invalid"  # NaN/inf/absurd peer estimate or flux
    SENSOR_DETACHED = "sensor_detached"  # holding the target takes far more current than the TEM needs


def trips_mask(trips: Iterable[Trip | str]) -> int:
    """The trips as a bit mask, bit i = the i-th member of :class:`Trip` in declaration order (objects 0x2706,
    0x2707): sensor_invalid 0x001, open_thermocouple 0x002, sensor_range 0x004, model_mismatch 0x008,
    surface_high 0x010, surface_low 0x020, time_at_temperature 0x040, heat_sink 0x080, overcurrent 0x100,
    peer_lost 0x200, peer_invalid 0x400, sensor_detached 0x800."""
    return sum(_TRIP_BIT[Trip(t)] for t in set(trips)) if trips else 0


_TRIP_BIT = {t: 1 << i for i, t in enumerate(Trip)}  # written every control cycle: computed once


def trips_from_mask(mask: int) -> list[Trip]:
    """Inverse of :func:`trips_mask` (unknown bits ignored)."""
    return [t for i, t in enumerate(Trip) if mask >> i & 1]


class ErrorRegisterBit(IntEnum):
    """Bits of the CiA 301 error register (object 0x1001)."""

    GENERIC = 0x01
    CURRENT = 0x02
    VOLTAGE = 0x04
    TEMPERATURE = 0x08
    COMMUNICATION = 0x10
    DEVICE_PROFILE = 0x20
    MANUFACTURER = 0x80


#: CiA 301 emergency error code of each trip (Table 21 classes: 0x2xxx current, 0x42xx device
#: temperature, 0x50xx device hardware, 0x8130 life guard / heartbeat error). A NaN or implausible peer value
#: is no CiA 301 communication error (the PDO was received and processed; 0x8210 means a PDO *not* processed
#: for its length, which the device raises itself): it has the device-specific code 0xFF02.
EMCY_CODES: dict[Trip, int] = {
    Trip.SENSOR_INVALID: 0x5010,
    Trip.OPEN_THERMOCOUPLE: 0x5011,
    Trip.SENSOR_RANGE: 0x5012,
    Trip.MODEL_MISMATCH: 0x5013,
    Trip.SURFACE_HIGH: 0x4210,
    Trip.SURFACE_LOW: 0x4220,
    Trip.TIME_AT_TEMPERATURE: 0x4211,
    Trip.HEAT_SINK: 0x4230,
    Trip.OVERCURRENT: 0x2310,
    Trip.PEER_LOST: EMCY_HEARTBEAT,
    Trip.PEER_INVALID: EMCY_PEER_INVALID,
    Trip.SENSOR_DETACHED: 0x5014,
}

#: Error-register bits each trip sets (GENERIC is always set while any trip is active).
ERROR_REGISTER_BITS: dict[Trip, int] = {
    Trip.SENSOR_INVALID: ErrorRegisterBit.MANUFACTURER,
    Trip.OPEN_THERMOCOUPLE: ErrorRegisterBit.MANUFACTURER,
    Trip.SENSOR_RANGE: ErrorRegisterBit.MANUFACTURER,
    Trip.MODEL_MISMATCH: ErrorRegisterBit.MANUFACTURER,
    Trip.SURFACE_HIGH: ErrorRegisterBit.TEMPERATURE,
    Trip.SURFACE_LOW: ErrorRegisterBit.TEMPERATURE,
    Trip.TIME_AT_TEMPERATURE: ErrorRegisterBit.TEMPERATURE,
    Trip.HEAT_SINK: ErrorRegisterBit.TEMPERATURE,
    Trip.OVERCURRENT: ErrorRegisterBit.CURRENT,
    Trip.PEER_LOST: ErrorRegisterBit.COMMUNICATION,
    Trip.PEER_INVALID: ErrorRegisterBit.MANUFACTURER,  # 0xFFxx: as the device's 0x1001 says
    Trip.SENSOR_DETACHED: ErrorRegisterBit.MANUFACTURER,
}

#: Trips after which the current is cut at once (the measurement cannot be trusted or the hardware
#: is at risk). The other trips ramp the setpoint (peer) or cap it (time at temperature).
CUT_TRIPS = frozenset(
    {
        Trip.SENSOR_INVALID,
        Trip.OPEN_THERMOCOUPLE,
        Trip.SENSOR_RANGE,
        Trip.MODEL_MISMATCH,
        Trip.SURFACE_HIGH,
        Trip.SURFACE_LOW,
        Trip.HEAT_SINK,
        Trip.OVERCURRENT,
        Trip.SENSOR_DETACHED,
    }
)
PEER_TRIPS = frozenset({Trip.PEER_LOST, Trip.PEER_INVALID})


def error_register(trips: frozenset[Trip] | tuple[Trip, ...]) -> int:
    """Value of object 0x1001 for the active ``trips`` (0 when none)."""
    reg = 0
    for t in trips:
        reg |= ERROR_REGISTER_BITS[t] | ErrorRegisterBit.GENERIC
    return reg
