"""The docstring examples of the public modules run as tests."""

import doctest
import importlib

import pytest

MODULES = ["tribench.ext", "tribench.workloads.reference", "tribench.harness.stats"]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0, f"{name} has no examples"
    assert result.failed == 0
