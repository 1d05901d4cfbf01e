"""The rendering table (telethermo/data/render_materials.toml): material -> relative effusivity β (yamamoto
eq. 6), in file order (a material's position is its code in the object dictionary). Standard library only,
so the light CLI commands (``telethermo status``) can name a material without importing numpy."""

from __future__ import annotations

import functools
import math
import tomllib
from pathlib import Path

DEFAULT_RENDER_TABLE = Path(__file__).resolve().parent.parent / "data" / "render_materials.toml"


def load_render_table(path: str | Path | None = None) -> dict[str, float]:
    """Material -> β from a rendering table (TOML); errors name the file and the field."""
    path = Path(path) if path is not None else DEFAULT_RENDER_TABLE
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ValueError(f"{path}: cannot read rendering table: {exc}") from exc
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{path}: not valid TOML: {exc}") from exc
    out: dict[str, float] = {}
    for name, entry in data.items():
        if not isinstance(entry, dict):
            raise ValueError(f"{path}: [{name}]: expected a table with 'beta', got {type(entry).__name__}")
        beta = entry.get("beta")
        if (
            isinstance(beta, bool)
            or not isinstance(beta, (int, float))
            or not math.isfinite(beta)
            or beta <= 0
        ):
            raise ValueError(f"{path}: [{name}].beta: expected a number > 0, got {beta!r}")
        out[name] = float(beta)
    if not out:
        raise ValueError(f"{path}: no materials")
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
