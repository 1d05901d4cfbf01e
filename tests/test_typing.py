"""mypy, configured in pyproject.toml ([tool.mypy]), is clean: a plain ``mypy`` in the project root checks
telethermo/control, telethermo/device, telethermo/ident and telethermo/recording with the strict flags and
reports no error.
Runs the mypy installed in the test's own interpreter (the .venv: ``make install`` puts it there through
the ``dev`` extra)."""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
STRICT_PACKAGES = ("telethermo/control", "telethermo/device", "telethermo/ident", "telethermo/recording")


def _mypy_config() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["mypy"]


def test_the_configuration_names_the_strict_packages():
    cfg = _mypy_config()
    assert set(cfg["files"]) == set(STRICT_PACKAGES)
    strict = [o for o in cfg["overrides"] if "disallow_untyped_defs" in o]
    assert strict and {m.replace(".*", "").replace(".", "/") for o in strict for m in o["module"]} >= set(
        STRICT_PACKAGES
    )
    for flag in ("disallow_untyped_defs", "disallow_any_generics", "warn_return_any", "strict_equality"):
        assert all(o.get(flag) is True for o in strict), flag


@pytest.mark.slow
def test_mypy_reports_no_error_on_the_strict_packages():
    if importlib.util.find_spec("mypy") is None:
        pytest.skip(
            "MYPY IS NOT INSTALLED in this interpreter: the strict type check did NOT run "
            "(run `make install`, which installs the dev extra)"
        )
    env = {k: v for k, v in os.environ.items() if not k.startswith("MYPY")}
    proc = subprocess.run(
        [sys.executable, "-m", "mypy"], cwd=ROOT, env=env, capture_output=True, text=True, timeout=900
    )
    out = proc.stdout + proc.stderr
    errors = [line for line in out.splitlines() if ": error:" in line]
    assert proc.returncode == 0 and not errors, f"mypy: {len(errors)} error(s)\n" + "\n".join(errors[:60])
    # it checked the packages (not an empty file list): at least their modules
    m = re.search(r"no issues found in (\d+) source files?", out)
    n_modules = sum(len(list((ROOT / p).rglob("*.py"))) for p in STRICT_PACKAGES)
    assert m and int(m.group(1)) >= n_modules, out
