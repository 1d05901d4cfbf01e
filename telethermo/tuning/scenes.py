"""The scenes a tuning objective averages over: the given telepresence scene and a perturbed variant.

The tuner sees the simulator only here and through the offline session (telethermo.offline): the
control package itself never imports ``sim``.
"""

from __future__ import annotations

import dataclasses
import os
from typing import Any

from telethermo import sim
from telethermo.offline.envelope import Condition, condition_scene, draw_conditions
from telethermo.sim.bodies import FingerParams

#: the seed of the tuner's envelope draws: disjoint from the envelope benchmark's evaluation design
#: (bench/envelope_bench.py, seed 222026), so gains are never judged on the draws they were tuned on
TUNE_ENVELOPE_SEED = 7


def perturbed_scene(scene: Any) -> Any:
    """A robustness variant of a telepresence scene: another room, another operator, other objects.

    Ambient 3 °C cooler (22 °C for the guiatni scene; objects start there), a finger with a 4/3 thicker
    epidermis (0.8 mm), 1.5× dermal perfusion and a core at most 36.5 °C, the probe pressing at most 5 N
    (contact resistance no longer zero) and the finger at most 6 N, objects of neighbouring materials
    (aluminium→copper, carbon steel→stainless steel, oak→PVC, ...) touched in a rotated order. Same
    timing as the original. (The scene's noise seed is changed too, but an offline session seeds the
    noise from its own ``seed`` argument: :class:`Objective` passes its ``seed`` to every scene.)
    """
    sc = sim.load_scene(scene) if isinstance(scene, (str, os.PathLike)) else scene
    swap = {
        "aluminium": "copper",
        "carbon_steel": "stainless_steel",
        "oak": "pvc",
        "copper": "aluminium",
        "stainless_steel": "carbon_steel",
        "pvc": "oak",
        "brass": "aluminium",
        "eps": "oak",
        "glass": "ceramic",
    }
    ambient = sc.ambient_C - 3.0
    objects = {
        k: dataclasses.replace(o, material=swap.get(o.material, o.material), T0_C=ambient)
        for k, o in sc.objects.items()
    }
    f = sc.finger
    layers = list(f.layers)
    if layers:
        m, t, w = layers[0]
        layers[0] = (m, t * 4.0 / 3.0, w)
    if len(layers) > 1:
        m, t, w = layers[1]
        layers[1] = (m, t, w * 1.5)
    finger = FingerParams(layers=tuple(layers), T_blood_C=f.T_blood_C, core_C=min(f.core_C, 36.5))
    names = [t.body for t in sc.slave_contacts]
    rot = names[1:] + names[:1] if names else names
    slave = tuple(
        dataclasses.replace(t, body=b, force_N=min(t.force_N, 5.0)) for t, b in zip(sc.slave_contacts, rot)
    )
    master = tuple(dataclasses.replace(t, force_N=min(t.force_N, 6.0)) for t in sc.master_contacts)
    return dataclasses.replace(
        sc,
        name=f"{sc.name}~perturbed",
        ambient_C=ambient,
        objects=objects,
        finger=finger,
        slave_contacts=slave,
        master_contacts=master,
        seed=(sc.seed or 0) + 100,
    )


def envelope_scenes(n: int, seed: int = TUNE_ENVELOPE_SEED) -> list[Any]:
    """``n`` §5.3 scenes drawn across the operating envelope (telethermo.offline.envelope: room, objects'
    temperature, materials and thickness, force, finger, noise) with the shipped TEM on both rigs: the tuner
    tunes the reference gains on the reference module, and the gain rule (telethermo.control.gain_rule)
    carries them to another module through its identified model. Seeded apart from the evaluation design."""
    shipped = {
        f: getattr(Condition(index=0, design="", materials=("oak", "oak", "oak")), f)
        for f in Condition.__dataclass_fields__
        if f[:2] in ("m_", "s_")
    }
    out = []
    for c in draw_conditions(n, seed, corners=False):
        sc, _ = condition_scene(dataclasses.replace(c, delay_ms=0.0, **shipped))
        out.append(dataclasses.replace(sc, name=f"envelope_tune_{c.index}"))
    return out


def tuning_scenes(scene: Any, *, perturbed: bool = True, envelope: int = 0) -> list[Any]:
    """The scenes an objective averages over: ``scene``, (default) its :func:`perturbed_scene`, and
    ``envelope`` draws across the operating envelope (:func:`envelope_scenes`)."""
    sc = sim.load_scene(scene) if isinstance(scene, (str, os.PathLike)) else scene
    if sc.kind != "telepresence":
        raise ValueError(
            f"tuning: scene {sc.name!r} is {sc.kind!r}; the bilateral gains need a telepresence scene"
        )
    return ([sc, perturbed_scene(sc)] if perturbed else [sc]) + (
        envelope_scenes(envelope) if envelope else []
    )
