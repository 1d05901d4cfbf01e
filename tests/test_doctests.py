"""The examples in the docstrings of the pure modules run and hold (doctest), and every module listed has
some: a module whose examples were deleted fails here rather than passing with nothing checked."""

from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = [
    "telethermo.control.pi",
    "telethermo.ident.prbs",
    "telethermo.control.estimators",
    "telethermo.cia301",
    "telethermo.offline.oscillation",
    "telethermo.offline.envelope",
    "telethermo.offline.bound",
    "telethermo.control.gain_rule",
    "telethermo.control.osc_guard",
    "telethermo.control.passive_bound",
    "telethermo.units",
]


@pytest.mark.parametrize("name", MODULES)
def test_the_docstring_examples_hold(name):
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS, verbose=False)
    assert result.attempted > 0, f"{name}: no doctest examples"
    assert result.failed == 0, f"{name}: {result.failed} of {result.attempted} doctest examples failed"
