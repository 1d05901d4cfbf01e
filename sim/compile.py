"""Compile a scene into simulated rigs (only the models each rig needs) and into the direct-touch
reference."""

from __future__ import annotations

import math
from dataclasses import replace

from telethermo.sim.errors import SceneError
from telethermo.sim.materials import material
from telethermo.sim.measurement import NoiseParams
from telethermo.sim.plant import Body, GridSettings
from telethermo.sim.rig import SimRig
from telethermo.sim.scene import Scene
from telethermo.sim.tem import RigParams, load_rig_params
from telethermo.sim.touch import BodySpec, Schedule

LUMP_BUDGET_C = 0.01
"""A slab is lumped only when the estimated internal non-uniformity at the first sample is below this, °C."""


def lump_error_estimate_C(spec: BodySpec, params: RigParams, t_min_s: float, dT_C: float = 15.0) -> float:
    """Estimated surface-vs-mean error of lumping a slab, °C: q(t_min)·L/(3λ), with q the semi-infinite
    contact flux between the flux sensor and the slab material for a ``dT_C`` step (q = ΔT·b_eff/√(π·t))."""
    mat = material(spec.material)
    bs = material(params.sensor_material).b
    b_eff = bs * mat.b / (bs + mat.b)
    q = dT_C * b_eff / math.sqrt(math.pi * t_min_s)
    return q * spec.thickness_m / (3.0 * mat.lambda_W_mK)


def _rig_bodies(
    scene: Scene,
    specs: dict[str, BodySpec],
    touched: set[str],
    params: RigParams,
    grid: GridSettings,
    prune: bool,
    report: list[str],
    rig: str,
) -> dict[str, Body]:
    bodies = {}
    for name, spec in specs.items():
        if prune and name not in touched:
            report.append(f"{rig}: {name}: not modelled (never touches this rig)")
            continue
        lumped = False
        if spec.kind == "slab":
            err = lump_error_estimate_C(spec, params, grid.t_min_s)
            if prune and err <= LUMP_BUDGET_C:
                lumped = True
                report.append(
                    f"{rig}: {name}: lumped (1 node; Biot-type error estimate {err:.3g} °C <= "
                    f"{LUMP_BUDGET_C} °C)"
                )
            elif prune:
                report.append(
                    f"{rig}: {name}: 1D grid kept (lumping error estimate {err:.3g} °C > {LUMP_BUDGET_C} °C)"
                )
        body = Body(spec, params.area_m2, scene.ambient_C, params.h_air_W_m2K, grid, lumped=lumped)
        bodies[name] = body
        if prune and name in touched:
            report.append(
                f"{rig}: {name}: {body.n} cells; integrated only while touching, advanced in one exact "
                f"step across each release"
            )
    return bodies


def build_rig(
    scene: Scene,
    role: str,
    seed: int | None = None,
    *,
    grid: GridSettings | None = None,
    prune: bool = True,
    noise: bool | None = None,
) -> SimRig:
    """The simulated rig ``role`` ("master" or "slave") of a scene.

    The master's pad carries the operator's finger per the master schedule; the slave's pad touches the
    scene's objects per the slave schedule. ``seed`` (default: the scene's noise.seed) seeds the sensor noise.
    ``prune=False`` builds every body of the scene into each rig and integrates detached bodies every step
    (the unpruned baseline of the benchmark). ``noise=False`` turns the noise off.
    """
    if role not in ("master", "slave"):
        raise ValueError(f"build_rig: role must be 'master' or 'slave', got {role!r}")
    if role not in scene.rigs:
        raise SceneError(scene.path, "scene.kind", f"a scene with a {role} rig ('telepresence')", scene.kind)
    report: list[str] = []
    if grid is None:
        grid, preset, err = GridSettings.for_tolerance(scene.tolerance_C, scene.period_s)
        report.append(
            f"{role}: grid '{preset}' (measured error {err} °C for tolerance {scene.tolerance_C} °C)"
        )
    params = scene.rig_params
    finger = BodySpec("finger", kind="finger", finger=scene.finger)
    if role == "master":
        touches = scene.master_contacts
        specs = {"finger": finger}
        if not prune:
            specs.update(scene.objects)
        if prune and scene.objects:
            report.append(
                f"master: objects {', '.join(sorted(scene.objects))}: not modelled (only the finger "
                f"touches the master)"
            )
    else:
        touches = scene.slave_contacts
        specs = dict(scene.objects)
        if prune:
            report.append("slave: finger: not modelled (no finger touches the slave)")
        else:
            specs["finger"] = finger
    touched = {t.body for t in touches}
    bodies = _rig_bodies(scene, specs, touched, params, grid, prune, report, role)
    np_ = scene.noise if noise is None or noise else replace(scene.noise, enabled=False)
    if not touches:
        report.append(f"{role}: pad touches nothing: air only")
    start = _start(scene, role, params, grid)
    try:
        return SimRig(
            params,
            bodies,
            Schedule(touches),
            ambient_C=scene.ambient_C,
            period_s=scene.period_s,
            noise=np_,
            seed=scene.seed if seed is None else seed,
            name=role,
            prune=prune,
            pruning=report,
            grid=grid,
            start=start,
        )
    except ValueError as exc:
        if start is None:
            raise
        raise SceneError(scene.path, f"{role}.start", f"a start the rig can hold ({exc})", start) from None


def finger_natural_C(scene: Scene, params: RigParams, grid: GridSettings) -> float:
    """The finger's natural skin temperature (steady state in the scene's air), °C."""
    body = Body(
        BodySpec("finger", kind="finger", finger=scene.finger),
        params.area_m2,
        scene.ambient_C,
        params.h_air_W_m2K,
        grid,
    )
    return body.surface_C()


def _start(scene: Scene, role: str, params: RigParams, grid: GridSettings) -> str | float | None:
    """The rig's settled start (sim.rig.SimRig ``start``): the master's as the scene says; the slave's
    "finger" is its pad held in air at the finger's natural skin temperature."""
    if role == "master":
        return scene.master_start
    if scene.slave_start == "finger":
        return finger_natural_C(scene, params, grid)
    return scene.slave_start


def free_pad_rig(
    period_s: float = 0.01,
    ambient_C: float = 25.0,
    seed: int | None = 0,
    noise: bool = True,
    params: RigParams | None = None,
) -> SimRig:
    """A rig whose pad touches nothing (air), for identification experiments."""
    params = params or load_rig_params()
    np_ = NoiseParams(enabled=noise)
    return SimRig(
        params,
        {},
        Schedule([]),
        ambient_C=ambient_C,
        period_s=period_s,
        noise=np_,
        seed=seed,
        name="free_pad",
        pruning=["free pad: no body modelled (the pad touches air only)"],
    )
