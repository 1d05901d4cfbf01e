"""Materials table: thermal conductivity, density, specific heat and effusivity, with sources.

The data live in ``sim/data/materials.toml``; :func:`materials` returns them as :class:`Material` objects.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from telethermo.inputfile import Section, load_toml
from telethermo.sim.errors import SceneError

DATA_DIR = Path(__file__).resolve().parent / "data"
MATERIALS_FILE = DATA_DIR / "materials.toml"


@dataclass(frozen=True, slots=True)
class Material:
    """Thermal properties of a homogeneous material (room temperature).

    Attributes:
        name: key in the materials table.
        lambda_W_mK: thermal conductivity, W/(m·K).
        rho_kg_m3: density, kg/m³.
        c_J_kgK: specific heat, J/(kg·K).
        source: where the numbers come from.
    """

    name: str
    lambda_W_mK: float
    rho_kg_m3: float
    c_J_kgK: float
    source: str = ""

    @property
    def rho_c_J_m3K(self) -> float:
        """Volumetric heat capacity, J/(m³·K)."""
        return self.rho_kg_m3 * self.c_J_kgK

    @property
    def diffusivity_m2_s(self) -> float:
        """Thermal diffusivity a = λ/(ρc), m²/s."""
        return self.lambda_W_mK / self.rho_c_J_m3K

    @property
    def b(self) -> float:
        """Thermal effusivity b = √(λρc), W·s^0.5/(m²·K)."""
        return math.sqrt(self.lambda_W_mK * self.rho_c_J_m3K)

    effusivity = b


def _load(path: Path) -> dict[str, Material]:
    top = Section(
        path,
        "",
        load_toml(path, SceneError, "a materials table"),
        {"materials"},
        error=SceneError,
        dotted=True,
    )
    table = top.table("materials", expected="a table of materials")
    if not table.raw:
        raise top.fail("materials", "a table of materials", {})
    out = {}
    for name in table.raw:
        props = table.table(name, {"lambda_W_mK", "rho_kg_m3", "c_J_kgK", "source"})
        vals = {key: props.float(key, positive=True) for key in ("lambda_W_mK", "rho_kg_m3", "c_J_kgK")}
        out[name] = Material(name=name, source=props.str("source", "", nonempty=False), **vals)
    return out


@lru_cache(maxsize=4)
def _cached(path: str) -> dict[str, Material]:
    return _load(Path(path))


def materials(path: str | Path | None = None) -> dict[str, Material]:
    """The materials table: name -> :class:`Material` (a fresh dict; the Materials are immutable)."""
    return dict(_cached(str(path or MATERIALS_FILE)))


def material(name: str) -> Material:
    """One material by name; KeyError listing the known names if absent."""
    table = materials()
    if name not in table:
        raise KeyError(f"unknown material {name!r}; known: {', '.join(sorted(table))}")
    return table[name]
