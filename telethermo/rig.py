"""The rig interface: the one small protocol between a controller and a rig (simulated or hardware).

A rig is one side of the system: heat sink -> TEM -> heat-flux sensor -> contact -> finger or object.

Sign conventions (used everywhere in the project):
- ``current_A`` > 0 heats the contact-side plate of the TEM (the pad); < 0 cools it.
- ``Q_W`` > 0 is heat flowing through the flux sensor from the TEM towards the contact side, i.e. out
  of the pad into whatever touches it (a finger being warmed, an object being warmed). A cold object
  touching a warm pad gives Q_W > 0; a warm finger on a cold pad gives Q_W < 0.

Time is the rig's own sample clock (s); a simulated rig advances only when asked
(:meth:`SimulatedRig.advance`), a hardware rig by itself.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable


@dataclass(frozen=True, slots=True)
class RigSample:
    """One measurement of a rig, as the controller sees it (after the rig's filter chain).

    Attributes:
        t_s: sample time, s.
        T_sensor_C: thermocouple at the heat-flux sensor's mid-plane, °C (filtered).
        Q_W: heat flux through the sensor, W (filtered); sign: see module docstring.
        current_A: the drive current measured in the TEM, A.
        contact: the rig's contact detector (IR detector / force switch): True while touched.
        T_sink_C: heat-sink temperature, °C (for the safety envelope's heat-sink trip).
        force_N: contact force if the rig measures it, N (0.0 when not touched / not measured).
    """

    t_s: float
    T_sensor_C: float
    Q_W: float
    current_A: float
    contact: bool
    T_sink_C: float
    force_N: float = 0.0


@runtime_checkable
class Rig(Protocol):
    """What a node needs of a rig. Implementations: sim.rig.SimRig, hardware drivers."""

    period_s: float
    """Control period the rig was configured for, s."""

    I_max_A: float
    """Hardware current limit of the TEM drive, A (the safety envelope allows 0.8 of it)."""

    def read(self) -> RigSample:
        """The latest sample."""
        ...

    def apply_current(self, current_A: float) -> None:
        """Command the TEM drive current, A (held until the next call)."""
        ...


@runtime_checkable
class SimulatedRig(Rig, Protocol):
    """A rig whose time advances only when asked (lockstep): one call per control period."""

    def advance(self, dt_s: float) -> None:
        """Integrate the plant by ``dt_s`` seconds holding the last commanded current."""
        ...
