"""CiA 301 facts, defined once: SDO abort codes (table 22) and EMCY error codes (table 21) as named
constants with their CiA 301 text, the predefined connection set's COB-IDs, NMT commands and states, and
the error-register (0x1001) bits.

Every module that sends, checks, decodes or prints these imports them from here (the control core's
safety envelope, the device's services, the node programs, the remote-node client, the CLI, the monitor,
the conformance checks). Pure data and lookup functions; no I/O.
"""

from __future__ import annotations

# --- SDO abort codes (CiA 301 v4.2 table 22) ------------------------------------------------------
ABORT_TOGGLE = 0x05030000  # toggle bit not alternated
ABORT_TIMEOUT = 0x05040000  # SDO protocol timed out
ABORT_COMMAND_SPECIFIER = 0x05040001  # client/server command specifier not valid or unknown
ABORT_BLOCK_SIZE = 0x05040002  # invalid block size (block mode only)
ABORT_SEQNO = 0x05040003  # invalid sequence number (block mode only)
ABORT_CRC = 0x05040004  # CRC error (block mode only)
ABORT_OUT_OF_MEMORY = 0x05040005
ABORT_UNSUPPORTED_ACCESS = 0x06010000
ABORT_WRITE_ONLY = 0x06010001  # attempt to read a write-only object
ABORT_READ_ONLY = 0x06010002  # attempt to write a read-only object
ABORT_NO_OBJECT = 0x06020000  # object does not exist in the object dictionary
ABORT_CANNOT_MAP = 0x06040041  # object cannot be mapped to the PDO
ABORT_PDO_TOO_LONG = 0x06040042  # number and length of mapped objects exceed the PDO length
ABORT_INCOMPATIBLE = 0x06040043  # general parameter incompatibility
ABORT_INTERNAL_INCOMPATIBLE = 0x06040047
ABORT_HARDWARE = 0x06060000
ABORT_LENGTH = 0x06070010  # data type / length of service parameter does not match
ABORT_LENGTH_HIGH = 0x06070012
ABORT_LENGTH_LOW = 0x06070013
ABORT_NO_SUBINDEX = 0x06090011  # sub-index does not exist
ABORT_RANGE = 0x06090030  # invalid value for parameter (value range exceeded, NaN)
ABORT_TOO_HIGH = 0x06090031  # value of parameter written too high
ABORT_TOO_LOW = 0x06090032  # value of parameter written too low
ABORT_MAX_BELOW_MIN = 0x06090036  # maximum value is less than minimum value
ABORT_NO_RESOURCE = 0x060A0023  # resource not available: SDO connection
ABORT_GENERAL = 0x08000000  # general error
ABORT_APPLICATION = 0x08000020  # data cannot be transferred or stored to the application
ABORT_LOCAL_CONTROL = 0x08000021  # ... because of local control
ABORT_DEVICE_STATE = 0x08000022  # ... because of the present device state
ABORT_NO_OD = 0x08000023
ABORT_NO_DATA = 0x08000024  # no data available

SDO_ABORT_CODES = {
    ABORT_TOGGLE: "Toggle bit not alternated",
    ABORT_TIMEOUT: "SDO protocol timed out",
    ABORT_COMMAND_SPECIFIER: "Client/server command specifier not valid or unknown",
    ABORT_BLOCK_SIZE: "Invalid block size (block mode only)",
    ABORT_SEQNO: "Invalid sequence number (block mode only)",
    ABORT_CRC: "CRC error (block mode only)",
    ABORT_OUT_OF_MEMORY: "Out of memory",
    ABORT_UNSUPPORTED_ACCESS: "Unsupported access to an object",
    ABORT_WRITE_ONLY: "Attempt to read a write only object",
    ABORT_READ_ONLY: "Attempt to write a read only object",
    ABORT_NO_OBJECT: "Object does not exist in the object dictionary",
    ABORT_CANNOT_MAP: "Object cannot be mapped to the PDO",
    ABORT_PDO_TOO_LONG: "The number and length of the objects to be mapped would exceed PDO length",
    ABORT_INCOMPATIBLE: "General parameter incompatibility reason",
    ABORT_INTERNAL_INCOMPATIBLE: "General internal incompatibility in the device",
    ABORT_HARDWARE: "Access failed due to a hardware error",
    ABORT_LENGTH: "Data type does not match, length of service parameter does not match",
    ABORT_LENGTH_HIGH: "Data type does not match, length of service parameter too high",
    ABORT_LENGTH_LOW: "Data type does not match, length of service parameter too low",
    ABORT_NO_SUBINDEX: "Sub-index does not exist",
    ABORT_RANGE: "Invalid value for parameter (download only)",
    ABORT_TOO_HIGH: "Value of parameter written too high (download only)",
    ABORT_TOO_LOW: "Value of parameter written too low (download only)",
    ABORT_MAX_BELOW_MIN: "Maximum value is less than minimum value",
    ABORT_NO_RESOURCE: "Resource not available: SDO connection",
    ABORT_GENERAL: "General error",
    ABORT_APPLICATION: "Data cannot be transferred or stored to the application",
    ABORT_LOCAL_CONTROL: "Data cannot be transferred or stored to the application because of local control",
    ABORT_DEVICE_STATE: (
        "Data cannot be transferred or stored to the application because of the present device state"
    ),
    ABORT_NO_OD: "Object dictionary dynamic generation fails or no object dictionary is present",
    ABORT_NO_DATA: "No data available",
}


def sdo_abort_text(code: int) -> str:
    """CiA 301 meaning of an SDO abort code ('unknown abort code' if not in table 22).

    >>> sdo_abort_text(ABORT_NO_OBJECT)
    'Object does not exist in the object dictionary'
    >>> sdo_abort_text(0x12345678)
    'unknown abort code'
    """
    return SDO_ABORT_CODES.get(code, "unknown abort code")


# --- EMCY error codes (CiA 301 v4.2 table 21) -----------------------------------------------------
EMCY_NO_ERROR = 0x0000  # error reset or no error
EMCY_HEARTBEAT = 0x8130  # life guard / heartbeat error (consumer timeout)
EMCY_BUS_OFF_RECOVERED = 0x8140  # recovered from bus off (telethermo: the node's bus is back)
EMCY_PDO_LENGTH = 0x8210  # PDO not processed due to length error
EMCY_PDO_LENGTH_EXCEEDED = 0x8220  # PDO length exceeded
EMCY_SYNC_LENGTH = 0x8240  # unexpected SYNC data length
EMCY_RPDO_TIMEOUT = 0x8250  # RPDO timeout (the RPDO event timer, 0x1400+n sub 5, expired)
EMCY_PEER_INVALID = 0xFF02  # manufacturer-specific: a peer value (RPDO1) NaN, infinite or
# implausible: the envelope's peer_invalid trip (control.trips)
EMCY_LINK_FALLBACK = 0xFF01  # manufacturer-specific: slave lost, the master renders the last
# identified material locally (telethermo.control.link_fallback)
EMCY_INPUT_SENTINEL = 0xFF10  # manufacturer-specific: an I/O module's analog input reads its sentinel
# (overload / open circuit); data: channel, the 16-bit code (iomodule)

EMCY_CODE_TEXTS = {
    EMCY_NO_ERROR: "Error reset or no error",
    0x1000: "Generic error",
    0x8110: "CAN overrun (objects lost)",
    0x8120: "CAN in error passive mode",
    EMCY_HEARTBEAT: "Life guard error or heartbeat error",
    EMCY_BUS_OFF_RECOVERED: "Recovered from bus off",
    0x8150: "CAN-ID collision",
    EMCY_PDO_LENGTH: "PDO not processed due to length error",
    EMCY_PDO_LENGTH_EXCEEDED: "PDO length exceeded",
    0x8230: "DAM MPDO not processed, destination object not available",
    EMCY_SYNC_LENGTH: "Unexpected SYNC data length",
    EMCY_RPDO_TIMEOUT: "RPDO timeout",
    EMCY_LINK_FALLBACK: "Device specific: peer lost, rendering the last identified material locally",
    EMCY_PEER_INVALID: "Device specific: peer value not plausible (NaN, infinite or out of range)",
    EMCY_INPUT_SENTINEL: "Device specific: an analog input reads its sentinel (overload or open circuit)",
}
#: the class of an EMCY code by its high byte (xx = any)
EMCY_CLASS_TEXTS = {
    0x00: "Error reset or no error",
    0x10: "Generic error",
    0x20: "Current",
    0x21: "Current, device input side",
    0x22: "Current inside the device",
    0x23: "Current, device output side",
    0x30: "Voltage",
    0x31: "Mains voltage",
    0x32: "Voltage inside the device",
    0x33: "Output voltage",
    0x40: "Temperature",
    0x41: "Ambient temperature",
    0x42: "Device temperature",
    0x50: "Device hardware",
    0x60: "Device software",
    0x61: "Internal software",
    0x62: "User software",
    0x63: "Data set",
    0x70: "Additional modules",
    0x80: "Monitoring",
    0x81: "Communication",
    0x82: "Protocol error",
    0x90: "External error",
    0xF0: "Additional functions",
    0xFF: "Device specific",
}


def emcy_code_text(code: int) -> str:
    """CiA 301 text of an EMCY error code: the exact entry if there is one, else its class.

    >>> emcy_code_text(EMCY_HEARTBEAT)
    'Life guard error or heartbeat error'
    >>> emcy_code_text(0x4210)          # no entry of its own: its class, 0x42xx
    'Device temperature'
    """
    if code in EMCY_CODE_TEXTS:
        return EMCY_CODE_TEXTS[code]
    return EMCY_CLASS_TEXTS.get(code >> 8) or EMCY_CLASS_TEXTS.get((code >> 8) & 0xF0, "unknown error code")


# --- COB-IDs of the predefined connection set (CiA 301 §7.3.3) -------------------------------
COB_NMT = 0x000
COB_SYNC = 0x080  # the SYNC default; EMCY is 0x080 + node-ID (0x081..0x0FF)
COB_TIME = 0x100
COB_SDO_TX = 0x580  # server -> client (response), + node-ID
COB_SDO_RX = 0x600  # client -> server (request), + node-ID
COB_HEARTBEAT = 0x700  # heartbeat / boot-up / node guarding, + node-ID
COB_LSS_TX, COB_LSS_RX = 0x7E4, 0x7E5

#: default COB-ID bases of PDO1..4 (TPDOn = base + node-ID)
DEFAULT_TPDO_BASE = (0x180, 0x280, 0x380, 0x480)
DEFAULT_RPDO_BASE = (0x200, 0x300, 0x400, 0x500)

# --- NMT --------------------------------------------------------------------------------------
NMT_COMMANDS = {
    0x01: "start",  # -> OPERATIONAL
    0x02: "stop",  # -> STOPPED
    0x80: "enter pre-operational",
    0x81: "reset node",
    0x82: "reset communication",
}
#: the state a node enters on each NMT command (resets end in PRE-OPERATIONAL after a boot-up)
NMT_COMMAND_TARGET = {
    0x01: "OPERATIONAL",
    0x02: "STOPPED",
    0x80: "PRE-OPERATIONAL",
    0x81: "INITIALISING",
    0x82: "INITIALISING",
}
#: heartbeat / node-guarding state byte (bit 7 is the guarding toggle bit)
NMT_STATES = {0x00: "INITIALISING", 0x04: "STOPPED", 0x05: "OPERATIONAL", 0x7F: "PRE-OPERATIONAL"}
NMT_UNKNOWN = "unknown"


def nmt_state_name(byte: int) -> str:
    """Name of a heartbeat state byte (toggle bit ignored); 'invalid 0xNN' for others.

    >>> nmt_state_name(0x85), nmt_state_name(0x7F), nmt_state_name(0x03)
    ('OPERATIONAL', 'PRE-OPERATIONAL', 'invalid 0x03')
    """
    code = byte & 0x7F
    return NMT_STATES.get(code, f"invalid 0x{code:02X}")


#: error register (0x1001) bits
ERROR_REGISTER_BITS = (
    "generic",
    "current",
    "voltage",
    "temperature",
    "communication",
    "device profile specific",
    "reserved",
    "manufacturer specific",
)


def error_register_names(reg: int) -> list[str]:
    """Names of the bits set in an error register byte (0x1001), bit 0 first.

    >>> error_register_names(0x11)
    ['generic', 'communication']
    """
    return [name for bit, name in enumerate(ERROR_REGISTER_BITS) if reg & (1 << bit)]
