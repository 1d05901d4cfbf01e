"""The material identification's shipped defaults, loaded once per process: the calibrated classifiers and
the rendering table's classes (telethermo.control.material_stream uses them as its parameters' defaults)."""

from __future__ import annotations

import functools
from pathlib import Path

from telethermo.control.material_calib import DEFAULT_CALIBRATION, Calibration, load_calibration
from telethermo.control.material_id import load_effusivity_table
from telethermo.control.rendering import load_render_table


@functools.lru_cache(maxsize=1)
def default_calibration() -> Calibration | None:
    """The shipped calibration (loaded once per process; None while none is shipped, e.g. before
    bench/material_calibrate.py has written it: the physics classification then; a malformed file raises)."""
    return load_calibration() if DEFAULT_CALIBRATION.exists() else None


@functools.lru_cache(maxsize=3)
def default_envelope(path: Path) -> Calibration | None:
    """A shipped envelope classifier (loaded once per process; None while it is not shipped)."""
    return load_calibration(path) if path.exists() else None


@functools.lru_cache(maxsize=1)
def default_classes() -> tuple[tuple[int, str, float], ...]:
    """(code, name, effusivity) of the default rendering table (code = 1-based position in the file)."""
    codes = {name: i + 1 for i, name in enumerate(load_render_table())}
    return tuple((codes[n], n, b) for n, b in load_effusivity_table().items())
