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


def user_render_table_text(betas: dict[str, float], how: str, base: str | Path | None = None) -> str:
    """A rendering table for one operator: ``base``'s materials in ``base``'s order (so their codes stay),
    each measured material's β replaced by ``betas[name]`` (its source says ``how``), the others kept with
    their source. Returns the TOML text; ValueError if ``betas`` names a material ``base`` lacks or gives a
    β that is not a finite positive number."""
    path = Path(base) if base is not None else DEFAULT_RENDER_TABLE
    top = Section(path, "", load_toml(path, what="a rendering table (TOML)"))
    unknown = sorted(set(betas) - set(top.raw))
    if unknown:
        raise ValueError(f"{path}: no material {', '.join(unknown)} (known: {', '.join(top.raw)})")
    lines = [
        f"# Rendering table of one operator: β measured from this finger's direct touches ({how});",
        f"# materials, order (= object-dictionary codes) and unmeasured entries from {path.name}.",
        "",
    ]
    for name, raw in top.raw.items():
        entry = dict(raw)
        if name in betas:
            b = float(betas[name])
            if not (b > 0.0 and b < float("inf")):
                raise ValueError(f"{name}: β must be a finite positive number, got {b!r}")
            entry["beta"] = b
            entry["source"] = f"measured ({how}); was {float(raw['beta']):.4g}: {raw.get('source', '')}"
        lines.append(f"[{name}]")
        for key in ("effusivity", "beta", "source"):
            if key in entry:
                v = entry[key]
                lines.append(f"{key} = {_toml_value(v)}")
        lines.append("")
    return "\n".join(lines)


def _toml_value(v: object) -> str:
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    return repr(float(v))  # type: ignore[arg-type]
