"""Test folders one-to-one with the packages (issue 26 item 6): every installed package P (``telethermo.P``,
from pyproject.toml) has its tests in ``tests/P``, and every folder under ``tests/`` is a package's or one of
the cross-cutting suites named below. A test of ``telethermo.transport`` is found in ``tests/transport``,
not next to the node programs that use the transport."""

from __future__ import annotations

import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TESTS = ROOT / "tests"

#: folders that are not a package's: suites selected by marker or run in their own place, and helpers
CROSS_CUTTING = {
    "vcan": "the SocketCAN tier (marker vcan; scripts/run-tests runs it natively or in the VM)",
    "stress": "the numerical-stability stress cases (marker stress; python -m bench.stress)",
    "conformance": "the CiA 301 checks of the live pair (marker conformance; bench.conformance_bench)",
    "support": "helpers for the tests (the results writer), no tests",
}


def packages() -> set[str]:
    """The installed subpackages of telethermo by their last name (``telethermo.sim`` -> ``sim``)."""
    listed = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["setuptools"][
        "packages"
    ]
    return {p.split(".")[1] for p in listed if p.count(".") == 1}


def folders_in_tests() -> set[str]:
    return {p.name for p in TESTS.iterdir() if p.is_dir() and not p.name.startswith((".", "__"))}


def modules_in(folder: Path) -> list[Path]:
    return sorted(folder.rglob("test_*.py"))


def test_every_package_has_its_tests_folder_with_tests():
    pkgs = packages()
    assert {"cli", "control", "device", "nodes", "sim", "bus_config", "transport", "offline"} <= pkgs
    missing = sorted(p for p in pkgs if not modules_in(TESTS / p))
    assert not missing, f"packages without tests/<package>/test_*.py: {missing}"


def test_every_tests_folder_is_a_package_or_a_named_suite():
    stray = sorted(folders_in_tests() - packages() - set(CROSS_CUTTING))
    assert not stray, (
        f"tests/ folders that are neither a package of pyproject.toml nor a cross-cutting suite: {stray} "
        "(move the tests to tests/<package they test>, or name the suite in CROSS_CUTTING with its reason)"
    )
    assert not set(CROSS_CUTTING) & packages(), "a package's folder is not a cross-cutting suite"


def test_the_helpers_folder_holds_no_tests():
    assert not modules_in(TESTS / "support")
