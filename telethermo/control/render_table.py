"""The rendering table (telethermo/data/render_materials.toml): material -> relative effusivity β (yamamoto
eq. 6), in file order (a material's position is its code in the object dictionary). Standard library only,
so the light CLI commands (``telethermo status``) can name a material without importing numpy."""

from __future__ import annotations

import functools
from pathlib import Path

from telethermo.inputfile import Section, load_toml

DEFAULT_RENDER_TABLE = Path(__file__).resolve().parent.parent / "data" / "render_materials.toml"
#: the keys of a material's table (beta, dimensionless; effusivity, W·s^½/(m²·K); source, text)
RENDER_KEYS = {"beta", "effusivity", "source"}


def load_render_table(path: str | Path | None = None) -> dict[str, float]:
    """Material -> β from a rendering table (TOML); errors name the file and the field."""
    path = Path(path) if path is not None else DEFAULT_RENDER_TABLE
    top = Section(path, "", load_toml(path, what="a rendering table (TOML)"))
    out = {
        name: top.table(name, RENDER_KEYS, expected="a table with 'beta'").float("beta", positive=True)
        for name in top.raw
    }
    if not out:
        raise top.fail(None, "at least one [material] table with 'beta'")
    return out


#: the identified-material code of an abstention (telethermo.control.material_stream.UNKNOWN_CODE, OD 0x2610)
UNKNOWN_CODE = 255


@functools.lru_cache(maxsize=4)
def _names(path: Path) -> tuple[str, ...]:
    return tuple(load_render_table(path))


def material_name(code: int, path: str | Path | None = None) -> str:
    """The name of material ``code`` of a rendering table (1-based, in file order: the object dictionary's
    material codes 0x2600/0x2610/0x2615); "unknown" for :data:`UNKNOWN_CODE` (the slave abstained), "none" for
    0 and for any other code past the table's end."""
    if code == UNKNOWN_CODE:
        return "unknown"
    names = _names(Path(path) if path is not None else DEFAULT_RENDER_TABLE)
    return names[code - 1] if 1 <= code <= len(names) else "none"
