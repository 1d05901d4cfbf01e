"""Data types of the control core's step-function contract (DESIGN.md §2).

The control core is pure: ``telethermo.control.core.step(sample, peer, params, state) -> StepResult``.
The same function runs offline (telethermo.offline) and inside the CANopen nodes (nodes/): a node
fills :class:`PeerValues` from its RPDO1 and the heartbeat consumer, calls ``step`` on every SYNC,
applies ``StepResult.current_A`` to the rig and sends ``StepResult.out`` in its TPDO1.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum, StrEnum


class Role(StrEnum):
    """Which side a controller runs on. A ``StrEnum``: it is its value wherever a string is expected (file
    keys, EDS/network sections, sim.build_rig, log lines), so no code converts between the two."""

    MASTER = "master"  # thermal display under the operator's finger; estimates T_f, tracks T_o
    SLAVE = "slave"  # robotic thermal probe; estimates T_o, tracks T_f


class Mode(IntEnum):
    """Operating mode; the integer is the value of the mode object in the object dictionary."""

    IDLE = 0  # current 0 (through the envelope's ramp), estimates still computed and sent
    TELEPRESENCE = 1  # bilateral coupling (guiatni eq. 34/35)
    RENDER = 2  # virtual material rendering, master alone (yamamoto)
    IDENTIFY = 3  # excitation (PRBS) for model identification; envelope still active


@dataclass(frozen=True, slots=True)
class PeerValues:
    """What a controller receives from its peer each cycle (RPDO1) plus the link state.

    Attributes:
        estimate_C: the peer's estimate: T_o (object, from the slave) on the master, T_f (finger,
            from the master) on the slave, °C. May be NaN/inf/absurd: the core must cope.
        flux_W: the peer's measured heat flux through its sensor, W (rig sign convention).
        fresh: True if a new value arrived for this cycle; False if the core is re-using an old one.
        alive: False once the node has declared the peer lost (heartbeat timeout or missing PDOs):
            the safety envelope then ramps to neutral and cuts current.
        contact: the peer's contact detector (the probe touches something), or None when the peer
            does not say (then the master treats the probe as touching: the published law).
        material_code: (from the slave) the material its last touch identified: code in the rendering
            table (1-based, as the OD's material_code), 0 none.
        material_beta: that material's relative effusivity b/b_skin as the slave estimated it (NaN none).
        material_touch: the slave's count of evaluated touches (a change = a new identification).
        material_T_object0_C: the identified object's initial temperature (the same fit), °C (NaN none).
    """

    estimate_C: float
    flux_W: float
    fresh: bool = True
    alive: bool = True
    contact: bool | None = None
    material_code: int = 0
    material_beta: float = float("nan")
    material_touch: int = 0
    material_T_object0_C: float = float("nan")


@dataclass(frozen=True, slots=True)
class Outgoing:
    """What a controller sends to its peer each cycle (TPDO1: REAL32 on the bus; the contact flag and, from
    the slave, the last identified material in the contact PDO: fields as in :class:`PeerValues`)."""

    estimate_C: float
    flux_W: float
    contact: bool = False
    material_code: int = 0
    material_beta: float = float("nan")
    material_touch: int = 0
    material_T_object0_C: float = float("nan")
