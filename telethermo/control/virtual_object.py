"""Virtual objects of the render mode: material, thickness and back condition (as the simulator's scene
objects).

    table = load_object_table()                      # telethermo/data/render_objects.toml
    obj = VirtualObject("aluminium", thickness_mm=1.0, back="adiabatic")
    props = table.get(obj.material)                  # ObjectMaterial: λ, ρc, b, a

The control core keeps its own table of thermal properties (it never imports ``sim``); aliases let the
rendering table's names ("wood", "contact_pad") find their material.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from telethermo.inputfile import Section, load_toml

DEFAULT_OBJECT_TABLE = Path(__file__).resolve().parent.parent / "data" / "render_objects.toml"
BACKS = ("adiabatic", "ambient")
#: loss of a free back face to still air, W/(m²·K) (natural convection + linearised radiation)
H_AIR_W_M2K = 15.0


@dataclass(frozen=True, slots=True)
class ObjectMaterial:
    """Thermal properties of one material. λ in W/(m·K), ρc in J/(m³·K)."""

    name: str
    lambda_W_mK: float
    rho_c_J_m3K: float
    source: str = ""

    @property
    def b(self) -> float:
        """Effusivity √(λρc), W·s^½/(m²·K)."""
        return math.sqrt(self.lambda_W_mK * self.rho_c_J_m3K)

    @property
    def diffusivity_m2_s(self) -> float:
        """a = λ/(ρc), m²/s."""
        return self.lambda_W_mK / self.rho_c_J_m3K


@dataclass(frozen=True, slots=True)
class ObjectTable:
    """Materials by name and alias, and the finger's reference effusivity (for β of unlisted objects)."""

    materials: dict[str, ObjectMaterial]
    aliases: dict[str, str]
    b_finger: float

    def get(self, name: str) -> ObjectMaterial:
        """The material called ``name`` (or an alias of it); ValueError naming the known ones."""
        key = self.aliases.get(name, name)
        if key not in self.materials:
            raise ValueError(
                f"virtual object: unknown material {name!r} (known: "
                f"{', '.join(sorted(set(self.materials) | set(self.aliases)))})"
            )
        return self.materials[key]

    def canonical(self, name: str) -> str:
        """The table's own name of ``name`` (aliases resolved)."""
        return self.get(name).name

    def beta(self, name: str) -> float:
        """β = b/b_finger of a material (for an object the rendering table does not list)."""
        return self.get(name).b / self.b_finger


@dataclass(frozen=True, slots=True)
class VirtualObject:
    """What the render mode renders: a slab of ``material`` (mm thick) with its back ``back``.

    Attributes:
        material: a name of the object table (or an alias).
        thickness_mm: slab thickness, mm (> 0).
        back: "adiabatic" (insulated back face) or "ambient" (back face loses to air at T_ambient_C).
        T_ambient_C: the air behind an "ambient" back, °C.
        area_m2: contact area (the pad's), m².
    """

    material: str
    thickness_mm: float
    back: str = "adiabatic"
    T_ambient_C: float = 25.0
    area_m2: float = 0.015 * 0.015

    def __post_init__(self) -> None:
        if not isinstance(self.material, str) or not self.material:
            raise ValueError(f"VirtualObject.material: expected a material name, got {self.material!r}")
        t = self.thickness_mm
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not (math.isfinite(t) and 0 < t <= 1000):
            raise ValueError(f"VirtualObject.thickness_mm: expected a thickness in (0, 1000] mm, got {t!r}")
        if self.back not in BACKS:
            raise ValueError(f"VirtualObject.back: expected one of {', '.join(BACKS)}, got {self.back!r}")
        if not (isinstance(self.area_m2, (int, float)) and 0 < self.area_m2 < 1):
            raise ValueError(f"VirtualObject.area_m2: expected an area in (0, 1) m², got {self.area_m2!r}")


def load_object_table(path: str | Path | None = None) -> ObjectTable:
    """Read the object table (TOML); errors name the file and the field."""
    path = Path(path) if path is not None else DEFAULT_OBJECT_TABLE
    top = Section(path, "", load_toml(path, what="an object table (TOML)"))
    b_f = top.table("finger", {"b_W_s05_m2K"}, {}).float("b_W_s05_m2K", positive=True)
    mats: dict[str, ObjectMaterial] = {}
    aliases: dict[str, str] = {}
    for name in top.raw:
        if name == "finger":
            continue
        e = top.table(name, {"lambda_W_mK", "rho_c_J_m3K", "source", "aliases"})
        mats[name] = ObjectMaterial(
            name,
            e.float("lambda_W_mK", positive=True),
            e.float("rho_c_J_m3K", positive=True),
            e.str("source", "", nonempty=False),
        )
        al = e.list("aliases", [], "an array of names")
        if not all(isinstance(a, str) for a in al):
            raise e.fail("aliases", "an array of names", al)
        for a in al:
            aliases[a] = name
    if not mats:
        raise top.fail(None, "at least one [material] table")
    return ObjectTable(mats, aliases, b_f)
