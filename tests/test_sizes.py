"""Small modules, one concept each: no module over 500 lines and no function over 80 lines in the
library, the node programs, the simulator, the bus configuration and the benchmark suite."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = ("telethermo", "nodes", "sim", "bus_config", "bench")
MAX_MODULE_LINES = 500
MAX_FUNCTION_LINES = 80


def sources():
    for folder in FOLDERS:
        yield from sorted((ROOT / folder).rglob("*.py"))


def long_functions(path: Path, limit: int) -> list[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    where = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path.name
    return [
        f"{where}:{n.lineno} {n.name} ({n.end_lineno - n.lineno + 1} lines)"
        for n in ast.walk(tree)
        if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)) and n.end_lineno - n.lineno + 1 > limit
    ]


def test_no_module_over_500_lines():
    big = [
        f"{p.relative_to(ROOT)} ({n} lines)"
        for p in sources()
        if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_MODULE_LINES
    ]
    assert not big, "modules over 500 lines:\n" + "\n".join(big)


def test_no_function_over_80_lines():
    long = [f for p in sources() for f in long_functions(p, MAX_FUNCTION_LINES)]
    assert not long, "functions over 80 lines:\n" + "\n".join(long)


def test_the_length_check_sees_a_long_function(tmp_path):
    body = "\n".join(f"    x{i} = {i}" for i in range(MAX_FUNCTION_LINES))
    f = tmp_path / "m.py"
    f.write_text(f"def short():\n    return 1\n\n\ndef long():\n{body}\n")
    assert [s.split()[1] for s in long_functions(f, MAX_FUNCTION_LINES)] == ["long"]


#: lines over 110 characters in telethermo/, nodes/, sim/, bus_config/, bench/ and tests/: none (issue 26);
#: ruff's E501 says the same at lint time (pyproject.toml), this test also counts what ruff is not shown.
MAX_LINE = 110


def long_lines(root: Path = ROOT) -> list[str]:
    out = []
    for folder in ("telethermo", "nodes", "sim", "bus_config", "bench", "tests"):
        for path in sorted((root / folder).rglob("*.py")):
            for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
                if len(line) > MAX_LINE:
                    out.append(f"{path.relative_to(root)}:{i}")
    return out


def test_no_line_over_110_characters():
    long = long_lines()
    assert not long, f"{len(long)} lines over {MAX_LINE} characters:\n" + "\n".join(long[:20])
