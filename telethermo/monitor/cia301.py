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


# --- SDO abort codes (table 22) and EMCY error codes (table 21) are in telethermo.canopen_dev.cia301

#: error register (0x1001) bits
ERROR_REGISTER_BITS = ("generic", "current", "voltage", "temperature", "communication",
                       "device profile specific", "reserved", "manufacturer specific")


def error_register_names(reg: int) -> list[str]:
    """Names of the bits set in an error register byte (0x1001), bit 0 first."""
    return [name for bit, name in enumerate(ERROR_REGISTER_BITS) if reg & (1 << bit)]
