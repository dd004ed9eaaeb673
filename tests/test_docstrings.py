"""The Examples sections of the docstrings run and give what they show."""

import doctest
import importlib
import pkgutil

import pytest

import inkray

MODULES = sorted(["inkray"] + [m.name for m in pkgutil.walk_packages(inkray.__path__, "inkray.")
                               if not m.name.startswith("inkray.examples")])


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE,
                             verbose=False, report=True)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples failed in {name}"
