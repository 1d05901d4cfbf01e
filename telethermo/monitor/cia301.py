"""CiA 301 facts the monitor decodes with: COB-ID ranges, NMT commands and states, SDO abort codes,
EMCY error codes and error-register bits (CiA 301 v4.2, tables 21, 22 and §7.2.8.3).

Pure data and lookup functions; no I/O.
"""
from __future__ import annotations

# --- COB-IDs of the predefined connection set (CiA 301 §7.3.3) -------------------------------
COB_NMT = 0x000
COB_SYNC = 0x080          # the SYNC default; EMCY is 0x080 + node-ID (0x081..0x0FF)
COB_TIME = 0x100
COB_SDO_TX = 0x580        # server -> client (response), + node-ID
COB_SDO_RX = 0x600        # client -> server (request), + node-ID
COB_HEARTBEAT = 0x700     # heartbeat / boot-up / node guarding, + node-ID
COB_LSS_TX, COB_LSS_RX = 0x7E4, 0x7E5

#: default COB-ID bases of PDO1..4 (TPDOn = base + node-ID)
DEFAULT_TPDO_BASE = (0x180, 0x280, 0x380, 0x480)
DEFAULT_RPDO_BASE = (0x200, 0x300, 0x400, 0x500)

# --- NMT --------------------------------------------------------------------------------------
NMT_COMMANDS = {
    0x01: "start",            # -> OPERATIONAL
    0x02: "stop",             # -> STOPPED
    0x80: "enter pre-operational",
    0x81: "reset node",
    0x82: "reset communication",
}
#: the state a node enters on each NMT command (resets end in PRE-OPERATIONAL after a boot-up)
NMT_COMMAND_TARGET = {0x01: "OPERATIONAL", 0x02: "STOPPED", 0x80: "PRE-OPERATIONAL",
                      0x81: "INITIALISING", 0x82: "INITIALISING"}
#: heartbeat / node-guarding state byte (bit 7 is the guarding toggle bit)
NMT_STATES = {0x00: "INITIALISING", 0x04: "STOPPED", 0x05: "OPERATIONAL", 0x7F: "PRE-OPERATIONAL"}
NMT_UNKNOWN = "unknown"


def nmt_state_name(byte: int) -> str:
    """Name of a heartbeat state byte (toggle bit ignored); 'invalid 0xNN' for others."""
    code = byte & 0x7F
    return NMT_STATES.get(code, f"invalid 0x{code:02X}")


# --- SDO abort codes (table 22) ---------------------------------------------------------------
SDO_ABORT_CODES = {
    0x05030000: "Toggle bit not alternated",
    0x05040000: "SDO protocol timed out",
    0x05040001: "Client/server command specifier not valid or unknown",
    0x05040002: "Invalid block size (block mode only)",
    0x05040003: "Invalid sequence number (block mode only)",
    0x05040004: "CRC error (block mode only)",
    0x05040005: "Out of memory",
    0x06010000: "Unsupported access to an object",
    0x06010001: "Attempt to read a write only object",
    0x06010002: "Attempt to write a read only object",
    0x06020000: "Object does not exist in the object dictionary",
    0x06040041: "Object cannot be mapped to the PDO",
    0x06040042: "The number and length of the objects to be mapped would exceed PDO length",
    0x06040043: "General parameter incompatibility reason",
    0x06040047: "General internal incompatibility in the device",
    0x06060000: "Access failed due to a hardware error",
    0x06070010: "Data type does not match, length of service parameter does not match",
    0x06070012: "Data type does not match, length of service parameter too high",
    0x06070013: "Data type does not match, length of service parameter too low",
    0x06090011: "Sub-index does not exist",
    0x06090030: "Invalid value for parameter (download only)",
    0x06090031: "Value of parameter written too high (download only)",
    0x06090032: "Value of parameter written too low (download only)",
    0x06090036: "Maximum value is less than minimum value",
    0x060A0023: "Resource not available: SDO connection",
    0x08000000: "General error",
    0x08000020: "Data cannot be transferred or stored to the application",
    0x08000021: "Data cannot be transferred or stored to the application because of local control",
    0x08000022: "Data cannot be transferred or stored to the application because of the present device state",
    0x08000023: "Object dictionary dynamic generation fails or no object dictionary is present",
    0x08000024: "No data available",
}


def sdo_abort_text(code: int) -> str:
    """CiA 301 meaning of an SDO abort code ('unknown abort code' if not in table 22)."""
    return SDO_ABORT_CODES.get(code, "unknown abort code")


# --- EMCY error codes (table 21) --------------------------------------------------------------
_EMCY_EXACT = {
    0x0000: "Error reset or no error",
    0x1000: "Generic error",
    0x8110: "CAN overrun (objects lost)",
    0x8120: "CAN in error passive mode",
    0x8130: "Life guard error or heartbeat error",
    0x8140: "Recovered from bus off",
    0x8150: "CAN-ID collision",
    0x8210: "PDO not processed due to length error",
    0x8220: "PDO length exceeded",
    0x8230: "DAM MPDO not processed, destination object not available",
    0x8240: "Unexpected SYNC data length",
    0x8250: "RPDO timeout",
}
_EMCY_HIGH_BYTE = {  # by the high byte (xx = any)
    0x00: "Error reset or no error", 0x10: "Generic error",
    0x20: "Current", 0x21: "Current, device input side", 0x22: "Current inside the device",
    0x23: "Current, device output side",
    0x30: "Voltage", 0x31: "Mains voltage", 0x32: "Voltage inside the device", 0x33: "Output voltage",
    0x40: "Temperature", 0x41: "Ambient temperature", 0x42: "Device temperature",
    0x50: "Device hardware",
    0x60: "Device software", 0x61: "Internal software", 0x62: "User software", 0x63: "Data set",
    0x70: "Additional modules",
    0x80: "Monitoring", 0x81: "Communication", 0x82: "Protocol error",
    0x90: "External error",
    0xF0: "Additional functions",
    0xFF: "Device specific",
}


def emcy_code_text(code: int) -> str:
    """CiA 301 text of an EMCY error code: the exact entry if there is one, else its class."""
    if code in _EMCY_EXACT:
        return _EMCY_EXACT[code]
    return _EMCY_HIGH_BYTE.get(code >> 8) or _EMCY_HIGH_BYTE.get((code >> 8) & 0xF0, "unknown error code")


#: error register (0x1001) bits
ERROR_REGISTER_BITS = ("generic", "current", "voltage", "temperature", "communication",
                       "device profile specific", "reserved", "manufacturer specific")


def error_register_names(reg: int) -> list[str]:
    """Names of the bits set in an error register byte (0x1001), bit 0 first."""
    return [name for bit, name in enumerate(ERROR_REGISTER_BITS) if reg & (1 << bit)]
