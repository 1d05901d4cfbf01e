"""Helpers shared by the simulator tests."""

from __future__ import annotations

import dataclasses

import pytest

from telethermo.sim.scene import parse_scene


def make_scene(
    master=(),
    slave=(),
    objects=None,
    kind=None,
    duration=5.0,
    period=0.01,
    ambient=25.0,
    noise=None,
    **scene_kw,
):
    """A scene from Python values (contacts as (start, end, object, force) tuples)."""
    raw = {
        "scene": {
            "name": "t",
            "kind": kind or ("telepresence" if slave or objects else "virtual"),
            "duration_s": duration,
            "period_s": period,
            "ambient_C": ambient,
            **scene_kw,
        },
        "objects": objects or {},
        "master": {"contacts": [{"start_s": s, "end_s": e, "force_N": f} for s, e, _, f in master]},
        "slave": {
            "contacts": [{"start_s": s, "end_s": e, "object": o, "force_N": f} for s, e, o, f in slave]
        },
    }
    if noise is not None:
        raw["noise"] = noise
    return parse_scene(raw, "<test>")


def perfect_contact(scene):
    """``scene`` with a negligible contact resistance (R''(1 N) = 1e-12 m²K/W): for tests of the bodies'
    effusivities against eq. 1, which assumes perfect contact (yamamoto measured β with silicone grease)."""
    return dataclasses.replace(scene, rig_params=scene.rig_params.with_(R_at_1N_m2K_W=1e-12))


@pytest.fixture
def scene_factory():
    return make_scene
