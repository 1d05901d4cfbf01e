"""The simulated operator's own rendering table: each material's β measured from this finger's direct
touches, as yamamoto measured Table 1 (one subject's contact temperatures on each sample).

β of eq. 1 is relative to a finger. The shipped table mixes yamamoto's subject (EPS 0.043, wood 0.74, brass
5.6) with b/b_epidermis for the other materials; the simulated finger is layered (epidermis on dermis, a
contact resistance that falls with force), and over the touch's first second it draws heat like a finger of
higher effusivity: EPS 0.015 and oak 0.37 instead of 0.043 and 0.41, aluminium 18 instead of 25. Rendered
with the shipped table, the display lands the finger 0.4–0.8 °C off its direct touch on EPS, oak, glass and
steel (bench/results/envelope.json, ``render_*``). A lab calibrates the same way from touches of its
samples (``telethermo calibrate-render-table``); this module does it on the simulator.

Each material is touched at :data:`CAL_T_OBJECT_C` (one colder and one warmer than the finger, neither on the
render sweep's 5 °C grid, so the sweep evaluates on temperatures the calibration never saw); β is the mean of
:func:`telethermo.control.rendering.relative_effusivity_from_contact` over those touches, with T_contact the
mean of the direct touch's skin in yamamoto's early window (0.1–1 s, as ``calibrate-finger`` reads it).
"""

from __future__ import annotations

import numpy as np

from telethermo import sim
from telethermo.control.rendering import relative_effusivity_from_contact
from telethermo.control.render_table import load_render_table
from telethermo.offline.one_touch import one_touch_scene

SCENE = "virtual_materials"
#: calibration object temperatures, °C (off the render sweep's 5 °C grid; one each side of the finger)
CAL_T_OBJECT_C = (12.5, 42.5)
#: the early window after contact, s (yamamoto; telethermo.cli.calibrate.EARLY)
EARLY_S = (0.1, 1.0)
#: rendering-table names whose simulated material has another name
SIM_MATERIAL = {"wood": "oak", "contact_pad": None}
T_ON_S, T_OFF_S = 3.0, 4.5


def direct_touch_beta(material: str, T_object_C: float, *, scene: str = SCENE) -> float:
    """β of ``material`` (a simulator material) relative to ``scene``'s finger from one direct touch of a
    20 mm slab at ``T_object_C``: (T_f0 − T_c)/(T_c − T_o), T_f0 the skin just before the touch, °C."""
    sc = one_touch_scene(scene, material, T_object_C, T_ON_S, T_OFF_S)
    ref = sim.build_reference(sc)
    dt = float(sc.period_s)
    t, skin = [], []
    while ref.t_s < T_OFF_S - dt / 2:
        ref.advance(dt)
        t.append(ref.t_s)
        skin.append(ref.T_contact_C)
    ta, sa = np.asarray(t), np.asarray(skin)
    T_f0 = float(sa[int(np.searchsorted(ta, T_ON_S - 1e-9)) - 1])
    win = (ta >= T_ON_S + EARLY_S[0]) & (ta <= T_ON_S + EARLY_S[1])
    return relative_effusivity_from_contact(T_f0, T_object_C, float(np.mean(sa[win])))


def simulated_user_betas(names: tuple[str, ...] | None = None, *, scene: str = SCENE) -> dict[str, float]:
    """β of each rendering-table material (all of them unless ``names``) for ``scene``'s finger: the mean
    over :data:`CAL_T_OBJECT_C`. Materials with no simulated twin (the contact pad: its β is the pad's,
    from ``calibrate-finger``) are left out."""
    out = {}
    for name in names if names is not None else tuple(load_render_table()):
        mat = SIM_MATERIAL.get(name, name)
        if mat is None:
            continue
        out[name] = float(np.mean([direct_touch_beta(mat, T, scene=scene) for T in CAL_T_OBJECT_C]))
    return out


def simulated_user_table(*, scene: str = SCENE) -> dict[str, float]:
    """The simulated operator's rendering table (material -> β): the shipped table with every material that
    has a simulated twin measured by :func:`simulated_user_betas`, and each renamed twin under its simulator
    name as well (``oak`` for ``wood``), so a scene object's material finds its β."""
    table = {**load_render_table(), **simulated_user_betas(scene=scene)}
    for name, mat in SIM_MATERIAL.items():
        if mat is not None and name in table:
            table[mat] = table[name]
    return table
