"""The one unit table: every unit a value of the project carries (on the bus, in a model file, in the bus
monitor), by its ASCII name (the EDS ``Unit=`` key, the model file's ``units``), with the symbol a person
reads, the quantity it measures (``kind``) and its scale; and the naming rule that gives a name's unit from
its suffix (``T_sensor_C`` degC, ``kp_A_per_C`` A/degC, ``R_sensor_K_per_W`` K/W; no suffix: no unit).

Temperatures are in degC; a temperature *difference* in K equals one in degC, so ``degC/W`` and ``K/W``
are one kind with the same scale. ``scale`` is the factor to the SI-coherent unit of the kind (``ms``
0.001 s).

>>> unit_of_name("kp_A_per_C"), unit_of_name("T_sensor_C"), unit_of_name("peer_pdo_miss_limit")
('A/degC', 'degC', '')
>>> UNITS["ms"].kind, UNITS["ms"].scale
('time', 0.001)
>>> same_quantity("degC/W", "K/W"), same_quantity("s", "ms")
(True, False)
"""

from __future__ import annotations

from dataclasses import dataclass

#: 0 °C in K: a Celsius temperature plus this is absolute (the Peltier term α·T wants kelvin)
KELVIN = 273.15


@dataclass(frozen=True)
class Unit:
    """One unit: ``name`` (ASCII), ``symbol`` (printed), ``kind`` (the quantity), ``scale`` (to SI)."""

    name: str
    symbol: str
    kind: str
    scale: float = 1.0
    aliases: tuple[str, ...] = ()
    """Other spellings an EDS of another vendor may write in its ``Unit=`` key."""

    @property
    def spellings(self) -> tuple[str, ...]:
        """Every text that names this unit: the name, the symbol, the aliases (no repeats)."""
        return tuple(dict.fromkeys((self.name, self.symbol, *self.aliases)))


#: unit name -> Unit
UNITS: dict[str, Unit] = {
    u.name: u
    for u in (
        Unit("degC", "°C", "temperature", aliases=("C",)),
        Unit("W", "W", "heat_flux"),
        Unit("A", "A", "current"),
        Unit("N", "N", "force"),
        Unit("s", "s", "time"),
        Unit("ms", "ms", "time", 0.001),
        Unit("mm", "mm", "length", 0.001),
        Unit("A/degC", "A/°C", "current/temperature"),
        Unit("A/(degC*s)", "A/(°C·s)", "current/(temperature*time)"),
        Unit("A/W", "A/W", "current/heat_flux"),
        Unit("degC/s", "°C/s", "temperature/time"),
        Unit("degC/W", "°C/W", "temperature/heat_flux"),
        Unit("K/W", "K/W", "temperature/heat_flux"),
    )
}

#: name suffix -> unit name: the project's naming convention (longest suffix first, the order to match in)
SUFFIXES: tuple[tuple[str, str], ...] = tuple(
    sorted(
        {
            "_A_per_C_s": "A/(degC*s)",
            "_A_per_C": "A/degC",
            "_A_per_W": "A/W",
            "_C_per_s": "degC/s",
            "_C_per_W": "degC/W",
            "_K_per_W": "K/W",
            "_C": "degC",
            "_W": "W",
            "_A": "A",
            "_N": "N",
            "_s": "s",
            "_ms": "ms",
            "_mm": "mm",
        }.items(),
        key=lambda item: -len(item[0]),
    )
)

#: the base unit of each kind a model file records, in the file's order
MODEL_KINDS = ("temperature", "current", "heat_flux", "time")


def unit_of_name(name: str) -> str:
    """The unit name the suffix of ``name`` implies ('' when it ends in none)."""
    for suffix, unit in SUFFIXES:
        if name.endswith(suffix):
            return unit
    return ""


def base_unit(kind: str) -> str:
    """The name of the unit of ``kind`` with scale 1 (the first in :data:`UNITS`)."""
    return next(u.name for u in UNITS.values() if u.kind == kind and u.scale == 1.0)


def spellings(name: str) -> tuple[str, ...]:
    """Every text that names the unit ``name`` (see :attr:`Unit.spellings`)."""
    return UNITS[name].spellings


def same_quantity(a: str, b: str) -> bool:
    """Whether units ``a`` and ``b`` measure the same kind on the same scale (a value needs no change)."""
    ua, ub = UNITS[a], UNITS[b]
    return ua.kind == ub.kind and ua.scale == ub.scale
