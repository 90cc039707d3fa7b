"""The packages import in one direction only, and no module imports itself back.

The order (docs/architecture.md, "Layout and data flow"), bottom first; a
sub-package named here is a layer of its own, above or below the rest of its
package:

    common <- ext <- workloads <- harness.stats <- harness <- harness.jobs
           <- reports.tables <- reports <- cli <- tribench (the notebook facade)

A module may import its own layer and any layer below it, never one above.
Every import counts: at module level, inside a function, under
``if TYPE_CHECKING``. Between modules there is no cycle, function-level
imports included, so each module can be read (and imported) knowing only what
is below it. Inside the package every import is relative, so that it resolves
from the files alone. And the docstrings stay at most 12% of the package's
Python lines (#52).
"""

from __future__ import annotations

import ast
from collections import deque
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
ORDER = [
    "common",
    "ext",
    "workloads",
    "harness.stats",
    "harness",
    "harness.jobs",
    "reports.tables",
    "reports",
    "cli",
    "",  # the facade, the package's own __init__.py
]
RANK = {layer: rank for rank, layer in enumerate(ORDER)}
PACKAGES = ["common", "ext", "workloads", "harness", "reports", "cli"]


@dataclass(frozen=True)
class Edge:
    """One import: ``source`` imports ``target`` at ``where`` (path:line)."""

    source: str
    target: str
    where: str
    absolute: bool = False

    def __str__(self) -> str:
        return f"{self.source} -> {self.target} ({self.where})"


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(["tribench", *parts])


def _sources() -> dict[str, Path]:
    """Every module of the package, by its import name (a compiled module by its stub)."""
    found = {"tribench": ROOT / "__init__.py"}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py*")):
            if path.suffix in (".py", ".pyi"):
                found[_module_name(path)] = path
    return found


MODULES = _sources()


def _resolve(base: str, names: list[str]) -> list[str]:
    """What ``from base import names`` loads: each name that is a module, else ``base`` itself."""
    targets = [f"{base}.{name}" for name in names if f"{base}.{name}" in MODULES]
    if len(targets) < len(names):
        targets.append(base)
    return targets


def _imports(module: str, path: Path) -> list[Edge]:
    """Every tribench import in one file, at any depth of the syntax tree."""
    is_package = path.name == "__init__.py"
    edges = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: climb from this module's package
                package = module.split(".") if is_package else module.split(".")[:-1]
                package = package[: len(package) - (node.level - 1)]
                base = ".".join(package + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            targets = _resolve(base, [alias.name for alias in node.names])
        else:
            continue
        where = f"{path.relative_to(ROOT)}:{node.lineno}"
        absolute = isinstance(node, ast.Import) or not node.level
        edges += [Edge(module, t, where, absolute) for t in targets if t == "tribench" or t.startswith("tribench.")]
    return edges


EDGES = [edge for module, path in MODULES.items() for edge in _imports(module, path)]


def _layer(module: str) -> str:
    """The layer of the order a module belongs to: its longest sub-package named there."""
    parts = module.split(".")[1:]
    for n in range(len(parts), -1, -1):
        if ".".join(parts[:n]) in RANK:
            return ".".join(parts[:n])
    raise AssertionError(module)


def test_the_scan_sees_every_layer_and_every_kind_of_import():
    # a scan that found nothing would pass everything below
    assert {_layer(m) for m in MODULES} == set(ORDER)
    assert len(EDGES) > 100
    pairs = {(e.source, e.target) for e in EDGES}
    assert ("tribench.harness.runner", "tribench.harness.runfolder") in pairs  # from . import module
    assert ("tribench.harness.runner", "tribench.harness.margin") in pairs  # relative, in a function
    assert ("tribench.reports.tables.pipeline", "tribench.harness.stats") in pairs  # from ..package import package
    assert ("tribench.cli.command", "tribench.harness.runner") in pairs  # in a function
    assert ("tribench.workloads.cache", "tribench.workloads.kinds") in pairs  # from .module import name
    assert ("tribench.ext.registry", "tribench.ext._core") in pairs  # the compiled module, by its stub


def test_every_import_inside_the_package_is_relative():
    absolute = [str(e) for e in EDGES if e.absolute]
    assert not absolute, "absolute imports of tribench inside it (import relatively):\n" + "\n".join(absolute)


def test_every_import_points_down_the_order():
    bad = []
    for edge in EDGES:
        source, target = _layer(edge.source), _layer(edge.target)
        if RANK[target] > RANK[source]:
            bad.append(f"{edge}: {source or 'tribench'} may not import {target or 'tribench'}")
    assert not bad, "imports against the order:\n" + "\n".join(bad)


def _cycles(edges: list[Edge]) -> list[list[Edge]]:
    """One cycle through each strongly connected group of modules (Tarjan)."""
    graph: dict[str, dict[str, Edge]] = {}
    for edge in edges:
        if edge.source != edge.target:
            graph.setdefault(edge.source, {}).setdefault(edge.target, edge)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    groups: list[set[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in graph.get(node, {}):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            group = set()
            while True:
                top = stack.pop()
                on_stack.discard(top)
                group.add(top)
                if top == node:
                    break
            if len(group) > 1:
                groups.append(group)

    for node in sorted(graph):
        if node not in index:
            visit(node)

    cycles = []
    for group in groups:  # the shortest way from the group's first module back to it
        start = min(group)
        came_by: dict[str, Edge] = {}
        queue = deque([start])
        while start not in graph[queue[0]]:
            node = queue.popleft()
            for nxt in sorted(graph[node]):
                if nxt in group and nxt != start and nxt not in came_by:
                    came_by[nxt] = graph[node][nxt]
                    queue.append(nxt)
        node = queue[0]
        path = [graph[node][start]]
        while node != start:
            path.insert(0, came_by[node])
            node = came_by[node].source
        cycles.append(path)
    return cycles


def test_no_module_imports_itself_back():
    cycles = _cycles(EDGES)
    assert not cycles, "import cycles:\n" + "\n".join("  " + "\n   ".join(map(str, c)) for c in cycles)


def test_the_cycle_finder_finds_a_cycle_and_names_its_edges():
    edges = [Edge("a", "b", "a.py:1"), Edge("b", "c", "b.py:2"), Edge("c", "a", "c.py:3"), Edge("c", "d", "c.py:4")]
    (cycle,) = _cycles(edges)
    assert [str(e) for e in cycle] == ["a -> b (a.py:1)", "b -> c (b.py:2)", "c -> a (c.py:3)"]
    assert _cycles(edges[:2] + edges[3:]) == []


@pytest.mark.parametrize("package", PACKAGES)
def test_each_package_says_what_it_owns_and_may_import(package):
    doc = ast.get_docstring(ast.parse((ROOT / package / "__init__.py").read_text(encoding="utf-8")))
    assert doc, f"{package}/__init__.py has no docstring"
    assert "may import" in doc, f"{package}/__init__.py: the docstring should say what the package may import"


MAX_DOCSTRING_SHARE = 0.12  # #52: docstrings give the contract and the reason; derivations live in docs/


def _docstring_lines(path: Path) -> tuple[int, int]:
    """(module, class and function docstring lines, all lines) of one file."""
    text = path.read_text(encoding="utf-8")
    doc = 0
    for node in ast.walk(ast.parse(text, filename=str(path))):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                if isinstance(first.value.value, str):
                    doc += (first.end_lineno or first.lineno) - first.lineno + 1
    return doc, len(text.splitlines())


def test_docstrings_are_a_small_share_of_the_package():
    counts = {str(path.relative_to(ROOT)): _docstring_lines(path) for path in MODULES.values() if path.suffix == ".py"}
    doc, total = sum(d for d, _ in counts.values()), sum(n for _, n in counts.values())
    assert total > 10_000  # the scan saw the package
    largest = sorted(counts.items(), key=lambda item: item[1][0], reverse=True)[:5]
    assert doc <= MAX_DOCSTRING_SHARE * total, (
        f"docstrings are {doc} of the package's {total} Python lines ({doc / total:.1%}, at most "
        f"{MAX_DOCSTRING_SHARE:.0%}): say the contract and the reason in a few lines, and move derivations and "
        "measurements to docs/. The most docstring lines: "
        + ", ".join(f"{name} ({d} of {n})" for name, (d, n) in largest)
    )


def test_the_facade_imports_under_any_name():
    """pytest imports the root's __init__.py as a plain module when the checkout's folder is no Python
    name (``tribench-ci-1``): it must import nothing of the package at module level."""
    import importlib.util
    import sys

    spec = importlib.util.spec_from_file_location("any_name", ROOT / "__init__.py")
    assert spec is not None and spec.loader is not None
    sys.modules["any_name"] = module = importlib.util.module_from_spec(spec)  # as an import does
    try:
        spec.loader.exec_module(module)
    finally:
        del sys.modules["any_name"]
    assert module.__all__[0] == "Results"


def test_run_json_is_read_as_a_typed_run_and_only_the_runner_touches_it_as_written():
    """#52: a run folder's record is one typed value; its JSON object (``Run.raw``) is the runner's, which
    rewrites the file, so no reader walks it as a dict."""
    users = sorted(
        str(path.relative_to(ROOT))
        for path in MODULES.values()
        if path.suffix == ".py"
        and any(isinstance(n, ast.Attribute) and n.attr == "raw" for n in ast.walk(ast.parse(path.read_text())))
    )
    assert users == ["harness/runner.py"]
