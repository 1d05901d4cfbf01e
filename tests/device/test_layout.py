"""The device layer's layout rules: canopen's private state is touched in one adapter module only (a
canopen upgrade breaks one file), no module over 500 lines, no function over 80 lines."""

from __future__ import annotations

import ast
from pathlib import Path

import telethermo.device as package

PACKAGE = Path(package.__file__).parent
ADAPTER = "canopen_adapter.py"


def _modules():
    return sorted(PACKAGE.glob("*.py"))


def _private_accesses(tree: ast.AST) -> list[str]:
    """``x._name`` where ``x`` is not ``self``/``cls`` (dunders aside): another object's private state."""
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and node.attr.startswith("_") and not node.attr.startswith("__"):
            if not (isinstance(node.value, ast.Name) and node.value.id in ("self", "cls")):
                out.append(f"line {node.lineno}: .{node.attr}")
    return out


def test_only_the_adapter_touches_private_state():
    found = {p.name: _private_accesses(ast.parse(p.read_text())) for p in _modules() if p.name != ADAPTER}
    assert {name: hits for name, hits in found.items() if hits} == {}
    assert _private_accesses(ast.parse((PACKAGE / ADAPTER).read_text()))  # the rule sees what it looks for


def test_modules_and_functions_stay_small():
    too_long = []
    for p in _modules():
        text = p.read_text()
        if text.count("\n") > 500:
            too_long.append(f"{p.name}: {text.count(chr(10))} lines")
        for node in ast.walk(ast.parse(text)):
            if (
                isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
                and node.end_lineno - node.lineno >= 80
            ):
                too_long.append(f"{p.name}: {node.name} {node.end_lineno - node.lineno + 1} lines")
    assert too_long == []
