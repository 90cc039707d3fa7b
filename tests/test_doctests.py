"""Every docstring example in the package runs as a test (found, not listed)."""

import doctest
import importlib
import pkgutil

import pytest

SUBPACKAGES = [
    "tribench.common",
    "tribench.ext",
    "tribench.workloads",
    "tribench.harness.stats",
    "tribench.harness",
    "tribench.harness.runfolder",
    "tribench.reports.tables",
    "tribench.harness.jobs",
    "tribench.reports",
    "tribench.cli",
]


def _has_examples(name: str) -> bool:
    return any(test.examples for test in doctest.DocTestFinder().find(importlib.import_module(name)))


def _modules() -> list[str]:
    names = []
    for package in SUBPACKAGES:
        names.append(package)
        pkg = importlib.import_module(package)
        names += [f"{package}.{m.name}" for m in pkgutil.iter_modules(pkg.__path__) if not m.name.startswith("_")]
    return [n for n in names if _has_examples(n)]


MODULES = _modules()


def test_the_modules_with_examples_are_found():
    assert {
        "tribench.common.files",
        "tribench.ext",
        "tribench.workloads.reference",
        "tribench.harness.stats.estimates",
        "tribench.reports.html",
        "tribench.harness.runfolder.doc",  # docs/run-folder.md's generator
    } <= set(MODULES)


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0
