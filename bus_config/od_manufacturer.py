"""The manufacturer-specific objects (0x2000..) of the two nodes' object dictionaries, generated entirely
from the two tables: the operator parameters (``bus_config/partable.py``) and every other object
(measurements, estimates, received peer values, the TEM model, commands, status, diagnostics:
``bus_config/objtable.py``). ``bus_config/edsgen.py`` writes them into master.eds and slave.eds with the
communication objects."""

from __future__ import annotations

from telethermo.bus_config.objtable import OBJECTS
from telethermo.bus_config.od_types import Obj
from telethermo.bus_config.partable import PARAMS, param_objects


def manufacturer_objects(role: str = "master") -> list[Obj]:
    """0x2000..: every row of both tables for ``role``, in index order."""
    params = param_objects(role, 0x2000, 0x5FFF)
    if len(params) != len(PARAMS):
        raise ValueError("bus_config/partable.py: a parameter outside 0x2000..0x5FFF")
    objs = [*params, *(o.obj() for o in OBJECTS)]
    indices = [o.index for o in objs]
    if len(set(indices)) != len(indices):
        twice = sorted({f"0x{i:04X}" for i in indices if indices.count(i) > 1})
        raise ValueError(f"bus_config/partable.py, objtable.py: index {', '.join(twice)} declared twice")
    return sorted(objs, key=lambda o: o.index)
