"""Every module and name that the package's text points to exists.

A docstring, comment or message that names ``tribench.x.y`` (or, in reST, a
relative ``:mod:`.y```) goes stale when the code moves; this reads every
source file and docs page and resolves each such name against the installed
package.
"""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ["common", "ext", "workloads", "harness", "reports", "cli"]
SOURCES = [ROOT / "__init__.py", *(p for d in PACKAGES for p in sorted((ROOT / d).rglob("*.py")))]
DOCS = sorted((ROOT / "docs").glob("*.md")) + [ROOT / "README.md"]
DOTTED = re.compile(r"\btribench(?:\.[A-Za-z_]\w*)+")
RELATIVE = re.compile(r":(?:mod|func|class|data|meth|attr):`~?(\.+[A-Za-z_][\w.]*)`")


def _module_of(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(["tribench", *parts])


def _resolves(dotted: str) -> bool:
    """``dotted`` is a module, or a module then attributes of it."""
    parts = dotted.split(".")
    for n in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:n]))
        except ImportError:
            continue
        for name in parts[n:]:
            if not hasattr(obj, name):
                return False
            obj = getattr(obj, name)
        return True
    return False


def _absolute(module: str, is_package: bool, relative: str) -> str:
    level = len(relative) - len(relative.lstrip("."))
    package = module.split(".") if is_package else module.split(".")[:-1]
    package = package[: len(package) - (level - 1)]
    return ".".join(package + [relative.lstrip(".")])


def _names(path: Path) -> set[str]:
    text = path.read_text(encoding="utf-8")
    found = {m.group(0).rstrip(".") for m in DOTTED.finditer(text)}
    if path.suffix == ".py":
        module = _module_of(path)
        found |= {_absolute(module, path.name == "__init__.py", m.group(1)) for m in RELATIVE.finditer(text)}
    return found


def test_the_scan_reads_the_package_and_finds_names():
    assert len(SOURCES) > 100 and any(ROOT / "harness" / "jobs" / "sweep.py" == p for p in SOURCES)
    assert sum(len(_names(p)) for p in SOURCES) > 100


def test_a_stale_name_is_caught():
    assert _resolves("tribench.harness.jobs.sweep.run_sweep")
    assert not _resolves("tribench.studies.finish")
    assert not _resolves("tribench.harness.jobs.sweep.no_such_function")


@pytest.mark.parametrize("path", SOURCES + DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_name_the_text_points_to_exists(path):
    stale = sorted(n for n in _names(path) if not _resolves(n))
    assert not stale, f"{path.relative_to(ROOT)} names what does not exist: {stale}"
