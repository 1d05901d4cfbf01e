"""The layer map of docs/architecture.md is true: every import of a project module, function-level ones
included, points down the table that page holds (the one place the layers are written), and the only
function-level imports of project modules are the CLI's lazy subcommand registry."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
ARCHITECTURE = ROOT / "docs" / "architecture.md"
# Source folders and the package name each installs as (pyproject.toml's package-dir).
SOURCES = {
    "telethermo": "telethermo",
    "sim": "telethermo.sim",
    "nodes": "telethermo.nodes",
    "bus_config": "telethermo.bus_config",
    "bench": "bench",
}
LAZY_REGISTRY = "telethermo.cli.main"


def layer_table() -> dict[str, int]:
    """Package -> layer number, read from the table under '## Layers' in docs/architecture.md."""
    text = ARCHITECTURE.read_text(encoding="utf-8")
    section = text.split("## Layers", 1)[1].split("\n## ", 1)[0]
    table: dict[str, int] = {}
    for line in section.splitlines():
        m = re.match(r"\|\s*(\d+)\s*\|([^|]*)\|", line)
        if m:
            for pkg in re.findall(r"`([\w.]+)`", m.group(2)):
                table[pkg] = int(m.group(1))
    if not table:
        raise AssertionError(f"{ARCHITECTURE}: no layer table under '## Layers'")
    return table


def modules() -> dict[str, Path]:
    """Every project module by its installed dotted name."""
    found = {}
    for folder, pkg in SOURCES.items():
        for path in sorted((ROOT / folder).rglob("*.py")):
            parts = list(path.relative_to(ROOT / folder).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            found[".".join([pkg, *parts])] = path
    return found


def owner(name: str, table: dict[str, int]) -> str | None:
    """The longest table entry that is ``name`` or a parent of it."""
    best = None
    for pkg in table:
        # the root package's row holds its own __init__ only, so a module missing from the table shows
        if (name == pkg or (pkg != "telethermo" and name.startswith(pkg + "."))) and (
            best is None or len(pkg) > len(best)
        ):
            best = pkg
    return best


def project_imports(mod: str, path: Path, known: set[str]):
    """(imported module, line, at function level) for every import of a project module."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    in_function: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            in_function.update(id(n) for n in ast.walk(node) if n is not node)
    is_pkg = path.name == "__init__.py"
    for node in ast.walk(tree):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = mod.split(".") if is_pkg else mod.split(".")[:-1]
                anchor = anchor[: len(anchor) - (node.level - 1)]
                base = ".".join([*anchor, base] if base else anchor)
            for a in node.names:
                full = f"{base}.{a.name}"
                targets.append(full if full in known else base)
        for t in dict.fromkeys(targets):
            if t.split(".")[0] in {"telethermo", "bench", "sim", "nodes", "bus_config"}:
                yield t, node.lineno, id(node) in in_function


def test_the_table_names_every_package_and_nothing_else():
    table = layer_table()
    mods = modules()
    unowned = sorted(m for m in mods if owner(m, table) is None)
    assert not unowned, f"modules in no layer of {ARCHITECTURE.name}: {unowned}"
    missing = sorted(p for p in table if p not in mods)
    assert not missing, f"{ARCHITECTURE.name} names packages that do not exist: {missing}"


def violations(mods: dict[str, Path], table: dict[str, int], known: set[str]) -> list[str]:
    """Every import in ``mods`` that does not point down ``table``."""
    wrong = []
    for mod, path in mods.items():
        src = owner(mod, table)
        for target, line, _ in project_imports(mod, path, known):
            where = f"{path.name if not path.is_relative_to(ROOT) else path.relative_to(ROOT)}:{line}"
            if target.split(".")[0] in {"sim", "nodes", "bus_config"}:
                wrong.append(
                    f"{where}: imports {target} by its folder name (installed as telethermo.{target})"
                )
                continue
            dst = owner(target, table)
            if dst is None:
                wrong.append(f"{where}: imports {target}, which is in no layer")
            elif dst != src and table[dst] >= table[src]:
                wrong.append(
                    f"{where}: {src} (layer {table[src]}) imports {target} ({dst}, layer {table[dst]})"
                )
    return wrong


def test_every_import_points_down_the_layer_map():
    mods = modules()
    wrong = violations(mods, layer_table(), set(mods))
    assert not wrong, "imports against the layer map:\n" + "\n".join(wrong)


def test_the_checker_reports_upward_sideways_and_late_imports(tmp_path):
    """The check itself: a control-core module importing the CLI (up), the simulator (sideways, same
    layer) and, inside a function, the offline harness is reported three times; a downward one is not."""
    fake = tmp_path / "fake.py"
    fake.write_text(
        "from telethermo.cli.main import main\nfrom telethermo.sim import rig\n"
        "from telethermo.rig import RigSample\n"
        "def f():\n    import telethermo.offline.runner\n"
    )
    mods = modules()
    wrong = violations({"telethermo.control.fake": fake}, layer_table(), set(mods))
    assert len(wrong) == 3, wrong
    late = [
        t for t, _, in_function in project_imports("telethermo.control.fake", fake, set(mods)) if in_function
    ]
    assert late == ["telethermo.offline.runner"]


def test_function_level_imports_of_project_modules_only_in_the_cli_registry():
    mods = modules()
    known = set(mods)
    late = [
        f"{path.relative_to(ROOT)}:{line}: {target}"
        for mod, path in mods.items()
        if mod != LAZY_REGISTRY
        for target, line, in_function in project_imports(mod, path, known)
        if in_function
    ]
    assert not late, "function-level imports of project modules (move them to the top):\n" + "\n".join(late)


@pytest.mark.parametrize(
    "low, high", [("telethermo.sim", "telethermo.control"), ("telethermo.control", "telethermo.sim")]
)
def test_the_simulator_and_the_controller_do_not_see_each_other(low, high):
    """The simulated rigs are an independent truth: neither package imports the other."""
    mods = modules()
    known = set(mods)
    seen = [
        f"{p.relative_to(ROOT)}:{line}"
        for m, p in mods.items()
        if m.startswith(low + ".") or m == low
        for t, line, _ in project_imports(m, p, known)
        if t == high or t.startswith(high + ".")
    ]
    assert not seen, f"{low} imports {high}: {seen}"


# Test modules that still import bench/: none (issue 26.4). The library code the benchmarks share with the
# tests lives under telethermo/ (the bound, the material touches, oracle and calibration, the RC cooling fit,
# the later-phase and link-loss figures, the monitor's traffic); a test of a benchmark's own orchestration
# runs it as a program. The list only shrinks: a module not listed that imports bench fails, and so does a
# listed one that no longer does (take it off).
STILL_IMPORTING_BENCH: set[str] = set()


def bench_importers(folder: Path, root: Path = ROOT) -> dict[str, list[int]]:
    """Modules under ``folder`` (paths relative to ``root``) that import bench, at any level -> the lines."""
    found: dict[str, list[int]] = {}
    for path in sorted(folder.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
            names = (
                [a.name for a in node.names]
                if isinstance(node, ast.Import)
                else [node.module or ""]
                if isinstance(node, ast.ImportFrom) and not node.level
                else []
            )
            if any(n == "bench" or n.startswith("bench.") for n in names):
                found.setdefault(path.relative_to(root).as_posix(), []).append(node.lineno)
    return found


def test_nothing_under_tests_imports_bench():
    """The tests are the test framework; bench/ is a tool that may run them (python -m bench.stress runs
    pytest on tests/stress), never a library the tests import."""
    found = bench_importers(ROOT / "tests")
    new = {f"{m}:{lines}" for m, lines in found.items() if m not in STILL_IMPORTING_BENCH}
    assert not new, f"test modules importing bench/: {sorted(new)}"
    gone = sorted(STILL_IMPORTING_BENCH - set(found))
    assert not gone, f"these no longer import bench/: take them off STILL_IMPORTING_BENCH: {gone}"


def test_the_bench_import_check_sees_every_form(tmp_path):
    (tmp_path / "a.py").write_text("import bench.stress\n")
    (tmp_path / "b.py").write_text("def f():\n    from bench import common\n")
    (tmp_path / "c.py").write_text("from benchmark import x\nfrom . import bench\nimport benchy\n")
    assert {Path(m).name for m in bench_importers(tmp_path, tmp_path)} == {"a.py", "b.py"}


# The node runtime composes its parts and hands each one the collaborators it uses (issue 26): no part
# reaches back into it, not even for a type under TYPE_CHECKING. Only the node program constructs it (and
# the nodes benchmark, which runs two of them in one process).
RUNTIME = "telethermo.nodes.runtime"
RUNTIME_USERS = {"telethermo.nodes.main", "bench.nodes_bench"}


def runtime_importers(mods: dict[str, Path]) -> list[str]:
    """``path:line`` of every import of the runtime in ``mods`` (any level, TYPE_CHECKING blocks included)."""
    known = set(mods) | {RUNTIME}
    return [
        f"{path.name if not path.is_relative_to(ROOT) else path.relative_to(ROOT)}:{line}"
        for mod, path in mods.items()
        if mod not in RUNTIME_USERS and mod != RUNTIME
        for target, line, _ in project_imports(mod, path, known)
        if target == RUNTIME
    ]


def test_no_part_imports_the_node_runtime():
    found = runtime_importers(modules())
    assert not found, f"modules importing {RUNTIME} (give them their collaborators instead): {found}"


def test_the_runtime_import_check_sees_type_checking_imports(tmp_path):
    fake = tmp_path / "part.py"
    fake.write_text(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
        "    from telethermo.nodes.runtime import NodeRuntime\n"
    )
    assert runtime_importers({"telethermo.nodes.part": fake}) == ["part.py:3"]


# The recording (issue 26.3) is one format for every path, so it sits below every path that writes or reads
# it: nothing in it may see the node programs, the offline harness, the CLI or the benchmarks.
RECORDING = "telethermo.recording"
ABOVE_THE_RECORDING = ("telethermo.nodes", "telethermo.offline", "telethermo.cli", "bench")


def recording_imports_above(mods: dict[str, Path]) -> list[str]:
    """``path:line: target`` of every import (any level) in the recording package of a package above it."""
    known = set(modules()) | set(mods)
    return [
        f"{path.name if not path.is_relative_to(ROOT) else path.relative_to(ROOT)}:{line}: {target}"
        for mod, path in mods.items()
        if mod == RECORDING or mod.startswith(RECORDING + ".")
        for target, line, _ in project_imports(mod, path, known)
        if any(target == up or target.startswith(up + ".") for up in ABOVE_THE_RECORDING)
    ]


def test_the_recording_package_is_in_the_layer_map_below_its_users():
    table = layer_table()
    assert RECORDING in table, f"{ARCHITECTURE.name}: no layer for {RECORDING}"
    for user in ABOVE_THE_RECORDING:
        assert table[RECORDING] < table[user], f"{RECORDING} (layer {table[RECORDING]}) not below {user}"
    assert any(m.startswith(RECORDING + ".") for m in modules()), f"{RECORDING} has no modules"


def test_the_recording_imports_no_nodes_offline_cli_or_bench():
    found = recording_imports_above(modules())
    assert not found, f"{RECORDING} imports a package above it: {found}"


def test_the_recording_import_check_sees_every_user_above(tmp_path):
    fake = tmp_path / "fake.py"
    fake.write_text(
        "import bench.report\nfrom telethermo.offline.runner import run_offline_session\n"
        "from telethermo.cli import session\nfrom telethermo.control.types import PeerValues\n"
        "def f():\n    from telethermo.nodes.launch import NodePair\n"
    )
    found = recording_imports_above({"telethermo.recording.fake": fake})
    assert {f.split(": ")[1] for f in found} == {
        "bench.report",
        "telethermo.offline.runner",
        "telethermo.cli.session",
        "telethermo.nodes.launch",
    }, found
