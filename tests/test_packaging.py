"""One installed top-level package: pyproject.toml lists every package folder, the simulator, the
node programs and the bus configuration install under ``telethermo.`` from their top-level folders,
and nothing installs a generic top-level name (sim, nodes, bench, bus_config)."""

from __future__ import annotations

import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def setuptools_table() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["setuptools"]


def test_every_package_folder_is_installed_under_telethermo():
    cfg = setuptools_table()
    listed = set(cfg["packages"])
    dirs = cfg.get("package-dir", {})
    expected = set()
    for folder, pkg in [("telethermo", "telethermo"), *[(v, k) for k, v in dirs.items()]]:
        for init in (ROOT / folder).rglob("__init__.py"):
            rel = init.parent.relative_to(ROOT / folder).parts
            expected.add(".".join([pkg, *rel]))
    assert listed == expected, (
        f"pyproject.toml packages: missing {sorted(expected - listed)}, extra {sorted(listed - expected)}"
    )
    assert all(p == "telethermo" or p.startswith("telethermo.") for p in listed)


def test_the_top_level_folders_keep_their_place():
    dirs = setuptools_table()["package-dir"]
    assert dirs == {
        "telethermo.sim": "sim",
        "telethermo.nodes": "nodes",
        "telethermo.bus_config": "bus_config",
    }
    for folder in dirs.values():
        assert (ROOT / folder / "__init__.py").is_file()
