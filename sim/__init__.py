"""Simulated rigs: the stand-in for hardware and the project's ground truth (see docs/sim.md).

    import sim
    scene = sim.load_scene("probe_touches_al_steel_wood")
    master, slave = sim.build_rig(scene, "master"), sim.build_rig(scene, "slave")
    ref = sim.build_reference(scene)

sim/ depends on numpy, scipy, tomllib and telethermo.rig only: it never uses the controller's models.
"""
from sim.compile import build_rig, free_pad_rig
from sim.errors import SceneError
from sim.materials import Material, materials
from sim.plant import GridSettings
from sim.reference import DirectTouch, build_reference
from sim.rig import RigTruth, SimRig
from sim.scene import Scene, load_scene, shipped_scenes
from sim.tem import load_tem_file

__all__ = ["build_rig", "free_pad_rig", "build_reference", "load_scene", "shipped_scenes", "materials",
           "Material", "Scene", "SceneError", "SimRig", "RigTruth", "DirectTouch", "GridSettings",
           "load_tem_file"]
