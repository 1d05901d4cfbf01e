"""What a ``telethermo set`` does to a node that drives current, said before it happens.

A safety limit written while the node runs a mode other than idle acts at its next control cycle. The
rule (docs/cli.md, "Live writes"): a write whose limit the node's present readings already break (the
heat sink above the new ``sink_trip_C``, the pad beyond the new ``T_max_C``/``T_min_C`` by more than the
envelope's trip margin, the model's mismatch above the new ``mismatch_limit_C``) would cut the current
through a latched trip: it is refused, nothing sent (exit 2), unless ``--force``; then it is sent and the
line says so. A write that narrows what the node does without a trip (a setpoint clamp, a current limit
below the present current) is sent, and one line says what changes. Gains are per mode: ``set`` says
which mode's gain it wrote (the node's mode at the time of the write).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from telethermo.control.gain_fields import SDO_GAIN_FIELDS
from telethermo.control.safety import SafetyLimits
from telethermo.control.types import Mode
from telethermo.remote.client import NodeClient
from telethermo.remote.errors import Failure, UserError
from telethermo.remote.targets import Target, lookup

#: gains kept per mode by the node (the per-mode rows of bus_config/partable.py)
GAIN_KEYS = frozenset(SDO_GAIN_FIELDS)
#: safety limits judged against the node's readings before a write
SAFETY_KEYS = frozenset({"sink_trip_C", "T_max_C", "T_min_C", "mismatch_limit_C", "current_limit_A"})
_DEFAULTS = SafetyLimits()


@dataclass(frozen=True)
class Consequence:
    """What a write will do: ``cut`` True when it latches a trip that cuts the current."""

    text: str
    cut: bool


def mode_name(code) -> str:
    return Mode(code).name.lower() if code in Mode._value2member_map_ else str(code)


def _read(node: NodeClient, t: Target, key: str) -> float:
    try:
        return float(node.read(lookup(t, key)))
    except (UserError, Failure, TypeError, ValueError):
        return math.nan


def node_mode(node: NodeClient, t: Target) -> int | None:
    """The node's mode (object ``mode``), None when its EDS has none or it cannot be read."""
    try:
        return int(node.read(lookup(t, "mode")))
    except (UserError, Failure, TypeError, ValueError):
        return None


def judge(node: NodeClient, t: Target, key: str, value: float) -> Consequence | None:
    """The consequence of writing ``value`` to safety limit ``key`` now; None when the node is idle (or has
    no mode object) or the present readings are inside the new limit."""
    if key not in SAFETY_KEYS:
        return None
    mode = node_mode(node, t)
    if mode is None or mode == int(Mode.IDLE):
        return None
    v = float(value)
    where = f"{t.role} in {mode_name(mode)}"
    if key == "sink_trip_C":
        sink = _read(node, t, "T_sink_C")
        if sink >= v:
            return Consequence(
                f"sink_trip_C {v:g} is below the heat sink's {sink:.1f} °C: the heat-sink trip "
                f"latches at the next cycle and the current is cut ({where})",
                True,
            )
    elif key in ("T_max_C", "T_min_C"):
        pad = _read(node, t, "T_sensor_C")
        margin = _DEFAULTS.surface_trip_margin_C
        beyond = pad - v if key == "T_max_C" else v - pad
        side = "above" if key == "T_max_C" else "below"
        if beyond > margin:
            return Consequence(
                f"{key} {v:g}: the pad at {pad:.1f} °C is {side} it by more than the envelope's "
                f"{margin:g} °C trip margin: the surface trip latches at the next cycle and the "
                f"current is cut ({where})",
                True,
            )
        if beyond > 0:
            return Consequence(
                f"{key} {v:g}: the pad at {pad:.1f} °C is {side} it: the setpoint is clamped to "
                f"{v:g} °C from the next cycle ({where})",
                False,
            )
    elif key == "mismatch_limit_C":
        gap = abs(_read(node, t, "T_pred_C") - _read(node, t, "T_sensor_C"))
        if math.isfinite(gap) and gap > v:
            return Consequence(
                f"mismatch_limit_C {v:g}: the model and the sensor differ by {gap:.1f} °C now: the "
                f"mismatch trip latches after {_DEFAULTS.mismatch_time_s:g} s and the current is "
                f"cut ({where})",
                True,
            )
    elif key == "current_limit_A":
        now = abs(_read(node, t, "current_A"))
        if math.isfinite(now) and now > v:
            return Consequence(
                f"current_limit_A {v:g}: the current of {now:.2f} A is limited to {v:g} A from "
                f"the next cycle ({where})",
                False,
            )
    return None


def gain_note(node: NodeClient, t: Target, key: str) -> str | None:
    """Which mode's gain a write of ``key`` changed (the node keeps one set per mode)."""
    if key not in GAIN_KEYS:
        return None
    mode = node_mode(node, t)
    if mode is None:
        return None
    return (
        f"  {key} written for the {mode_name(mode)} mode (the node's mode now); each mode keeps its own "
        f"gains: set it again after `telethermo mode ...` to change another mode's"
    )
