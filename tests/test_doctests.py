"""Run the docstring examples of the foundation modules (they are documentation: keep them true)."""

from __future__ import annotations

import doctest
import importlib

import pytest

FOUNDATION_MODULES = [
    "atmoscatter._validate",
    "atmoscatter.phase",
    "atmoscatter.geometry",
    "atmoscatter.atmosphere",
    "atmoscatter.scattering",
    "atmoscatter.optical_length",
    "atmoscatter.presets",
    "atmoscatter.solar",
    "atmoscatter.colour",
    "atmoscatter.standard_atmosphere",
]


@pytest.mark.parametrize("name", FOUNDATION_MODULES)
def test_doctests(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE, verbose=False)
    assert result.failed == 0, f"{result.failed} doctest(s) failed in {name}"


def test_doctests_exist():
    # the modules with examples must actually run some (guards against a silent no-op)
    attempted = 0
    for name in FOUNDATION_MODULES:
        finder = doctest.DocTestFinder()
        attempted += sum(len(t.examples) for t in finder.find(importlib.import_module(name)))
    assert attempted >= 8
