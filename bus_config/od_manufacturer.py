"""The manufacturer-specific objects (0x2000..) of the two nodes' object dictionaries, in groups: measurements
and control, the TEM model, safety/mode/rendering/material identification, identification/status/diagnostics.
The groups live in ``od_measurement_model.py`` (0x2000..0x2311) and ``od_material_status.py`` (0x240A..),
one function per index range. ``bus_config/edsgen.py`` writes them into master.eds and slave.eds with the
communication objects. The
operator parameters (gains, estimator, R_sensor, safety limits, mode, rendering, link loss, identification
plan) are rows of ``bus_config/partable.py``, inserted here by index (:func:`with_params`)."""

from __future__ import annotations

from telethermo.bus_config.od_material_status import (
    objects_240a_2615,
    objects_2616_261b,
    objects_261c_2620,
    objects_2807_280e,
    objects_2700_2707,
    objects_2708_2722,
)
from telethermo.bus_config.od_measurement_model import (
    objects_2000_2102,
    objects_2103_2105,
    objects_2300_230c,
    objects_230d_2311,
)
from telethermo.bus_config.od_types import Obj
from telethermo.bus_config.partable import param_objects


def with_params(objs: list[Obj], role: str) -> list[Obj]:
    """``objs`` with the operator parameters of bus_config/partable.py, each inserted before the first
    object of a higher index (the groups above are in index order, the status group after them)."""
    out = list(objs)
    for p in param_objects(role, 0x2000, 0x5FFF):
        out.insert(next((i for i, o in enumerate(out) if o.index > p.index), len(out)), p)
    return out


def manufacturer_objects(role: str = "master") -> list[Obj]:
    """0x2000..: measurements, estimates, gains, model, safety, mode, rendering, status, diagnostics."""
    V = lambda idx, var: Obj(idx, var.name, var=var)  # noqa: E731
    hand = [
        *objects_2000_2102(V),
        *objects_2103_2105(V),
        *objects_2300_230c(V),
        *objects_230d_2311(V),
        *objects_240a_2615(V),
        *objects_2616_261b(V),
        *objects_261c_2620(V),
        *objects_2807_280e(V),
        *objects_2700_2707(V),
        *objects_2708_2722(V),
    ]
    return with_params(hand, role)
