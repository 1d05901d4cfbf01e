"""One touch of one slab: the scene the render sweep and the simulated operator's calibration both run."""

from __future__ import annotations

import dataclasses
from typing import Any

from telethermo import sim


def one_touch_scene(
    scene: str, material: str, T_object_C: float, t_on_s: float, t_off_s: float, thickness_m: float = 0.02
) -> Any:
    """``scene`` (a scene name) with one object: a ``thickness_m`` (m) slab of ``material`` at ``T_object_C``,
    °C, touched by its first master contact from ``t_on_s`` to ``t_off_s`` (s), where the session ends. The
    object keeps everything else of the scene's first object (area, back condition)."""
    sc0 = sim.load_scene(scene)
    obj = dataclasses.replace(
        next(iter(sc0.objects.values())),
        name="o",
        material=material,
        T0_C=T_object_C,
        thickness_m=thickness_m,
    )
    touch = dataclasses.replace(sc0.master_contacts[0], render="o", start_s=t_on_s, end_s=t_off_s)
    return dataclasses.replace(sc0, objects={"o": obj}, master_contacts=(touch,), duration_s=t_off_s)
