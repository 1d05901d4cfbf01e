"""The CANopen device layer: CiA 301 behaviour over canopen.LocalNode (DESIGN.md §4).

Modules: :mod:`.device` (the thin Device composing one module per service: :mod:`.nmt`,
:mod:`.sdo_gate` with :mod:`.sdo_block`, :mod:`.pdo_engine` with :mod:`.pdo`, :mod:`.sync_consumer`,
:mod:`.heartbeat`, :mod:`.emcy_producer` with :mod:`.emcy`, :mod:`.od_access`), :mod:`.sync` (SYNC
producer), :mod:`.measure` (a device-only lockstep speed check),
:mod:`.cia301` (SDO abort and EMCY codes), :mod:`.canopen_adapter` (canopen's private state),
:mod:`.context`, :mod:`.events`, :mod:`.frames`, :mod:`.scheduler` (one timer thread per device),
:mod:`.eds_info` (limits, units and names from the EDS text), :mod:`.netconfig` (network.toml),
:mod:`.settings` (power-on overrides). See docs/canopen.md.
"""

from telethermo.device.device import (
    Device,
    DeviceStats,
    NmtCommand,
    NmtState,
    OdWriteError,
    PeerEvent,
    RpdoEvent,
    SyncTick,
    WriteEvent,
)
from telethermo.device.eds_info import EdsError, EdsInfo, VarInfo
from telethermo.device.netconfig import NetworkConfig, NetworkConfigError, load_network
from telethermo.device.settings import DeviceSettings
from telethermo.device.sync import SyncProducer

__all__ = [
    "Device",
    "DeviceStats",
    "NmtCommand",
    "NmtState",
    "OdWriteError",
    "PeerEvent",
    "RpdoEvent",
    "SyncTick",
    "WriteEvent",
    "EdsError",
    "EdsInfo",
    "VarInfo",
    "NetworkConfig",
    "NetworkConfigError",
    "load_network",
    "DeviceSettings",
    "SyncProducer",
]
