"""Simulated rigs: the stand-in for hardware and the project's ground truth (see docs/sim.md).

    from telethermo import sim
    scene = sim.load_scene("probe_touches_al_steel_wood")
    master, slave = sim.build_rig(scene, "master"), sim.build_rig(scene, "slave")
    ref = sim.build_reference(scene)

sim/ depends on numpy, scipy, telethermo.rig and telethermo.inputfile (the TOML reader) only: it never uses
the controller's models.
"""

from telethermo.sim.compile import build_rig, free_pad_rig
from telethermo.sim.errors import SceneError
from telethermo.sim.materials import Material, materials
from telethermo.sim.plant import GridSettings
from telethermo.sim.reference import DirectTouch, build_reference
from telethermo.sim.rig import RigTruth, SimRig
from telethermo.sim.scene import Scene, load_scene, shipped_scenes
from telethermo.sim.tem import load_tem_file

__all__ = [
    "build_rig",
    "free_pad_rig",
    "build_reference",
    "load_scene",
    "shipped_scenes",
    "materials",
    "Material",
    "Scene",
    "SceneError",
    "SimRig",
    "RigTruth",
    "DirectTouch",
    "GridSettings",
    "load_tem_file",
]
