"""The CAN controller's state and error counters as far as the interface reports them.

Two sources: python-can's ``bus.state`` (ACTIVE / PASSIVE / ERROR = bus-off), which only some
interfaces implement (pcan, ixxat, systec, etas; on the others, e.g. ``virtual``, ``socketcand`` and
``socketcan``, the base class answers ACTIVE whatever happens, so the monitor says "unavailable"),
and SocketCAN error frames (linux/can/error.h: the class bits in the identifier, the controller
status in data[1], the TX/RX error counters in data[6]/data[7]). Pure: the caller polls the bus.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

# linux/can/error.h: error class (in the identifier) and controller status (data[1])
ERR_CLASSES = (
    (0x001, "TX timeout"),
    (0x002, "lost arbitration"),
    (0x004, "controller"),
    (0x008, "protocol violation"),
    (0x010, "transceiver"),
    (0x020, "no ACK"),
    (0x040, "bus-off"),
    (0x080, "bus error"),
    (0x100, "restarted"),
    (0x200, "counters"),
)
CTRL_BITS = (
    (0x01, "RX overflow"),
    (0x02, "TX overflow"),
    (0x04, "RX warning"),
    (0x08, "TX warning"),
    (0x10, "RX passive"),
    (0x20, "TX passive"),
    (0x40, "back to error-active"),
)
CAN_ERR_CNT = 0x200
ACTIVE, WARNING, PASSIVE, BUS_OFF = "ERROR-ACTIVE", "WARNING", "ERROR-PASSIVE", "BUS-OFF"


def decode_error_frame(can_id: int, data: bytes) -> dict[str, Any]:
    """The classes, controller status and (when the driver gives them) error counters of a SocketCAN
    error frame; ``state`` is the controller state the frame implies, or None."""
    classes = [name for bit, name in ERR_CLASSES if can_id & bit]
    ctrl = data[1] if len(data) > 1 else 0
    status = [name for bit, name in CTRL_BITS if ctrl & bit] if can_id & 0x004 else []
    out: dict[str, Any] = {
        "classes": classes,
        "controller": status,
        "tx_errors": None,
        "rx_errors": None,
        "state": None,
    }
    if len(data) >= 8 and (can_id & CAN_ERR_CNT or data[6] or data[7]):
        out["tx_errors"], out["rx_errors"] = data[6], data[7]
    if can_id & 0x040:
        out["state"] = BUS_OFF
    elif ctrl & 0x30 and can_id & 0x004:
        out["state"] = PASSIVE
    elif ctrl & 0x0C and can_id & 0x004:
        out["state"] = WARNING
    elif (ctrl & 0x40 and can_id & 0x004) or can_id & 0x100:
        out["state"] = ACTIVE
    return out


@dataclass
class ControllerHealth:
    """What the monitor knows of the CAN controller.

    Attributes:
        state: ERROR-ACTIVE, WARNING, ERROR-PASSIVE, BUS-OFF or None (not known).
        source: where ``state`` came from ("bus.state", "error frame"), or why it is unavailable.
        tx_errors / rx_errors: the controller's error counters (0..255) from the last error frame
            that carried them, or None.
    """

    state: str | None = None
    source: str = "not polled yet"
    tx_errors: int | None = None
    rx_errors: int | None = None

    def from_error_frame(self, info: dict[str, Any]) -> None:
        if info["state"] is not None:
            self.state, self.source = info["state"], "error frame"
        if info["tx_errors"] is not None:
            self.tx_errors, self.rx_errors = info["tx_errors"], info["rx_errors"]

    def from_bus_state(self, name: str | None, reason: str = "") -> None:
        """``name``: python-can's BusState name (ACTIVE, PASSIVE, ERROR) or None with the ``reason``."""
        if name is None:
            if self.source != "error frame":
                self.state, self.source = None, reason
            return
        self.state = {"ACTIVE": ACTIVE, "PASSIVE": PASSIVE, "ERROR": BUS_OFF}.get(name, name)
        self.source = "bus.state"

    def text(self) -> str:
        if self.state is None:
            st = f"controller: unavailable ({self.source})"
        else:
            st = f"controller: {self.state} (from {self.source})"
        if self.tx_errors is not None:
            st += f"  TX errors {self.tx_errors}  RX errors {self.rx_errors}"
        return st

    def to_json(self) -> dict[str, Any]:
        return {
            "state": self.state,
            "source": self.source,
            "tx_errors": self.tx_errors,
            "rx_errors": self.rx_errors,
        }
