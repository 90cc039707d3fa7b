"""The notebook API (``import tribench``): the facade's functions, its docstring and docs/notebook.md, run."""

from __future__ import annotations

import doctest
import re
import subprocess
import sys
from pathlib import Path

import pytest
from test_report_run import run_fixture_dir

import tribench
from tribench.common import UserError
from tribench.harness import runfolder

PAGE = Path(__file__).resolve().parents[1] / "docs" / "notebook.md"


@pytest.fixture(scope="module")
def fixture_run(tmp_path_factory):
    run, cache = run_fixture_dir(tmp_path_factory)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("TRIBENCH_CACHE", str(cache))
        yield run


def test_the_docstring_example_runs(fixture_run):
    # the examples read a run folder: this test gives them one as ``run_dir``
    tests = doctest.DocTestFinder().find(tribench, globs={"run_dir": fixture_run})
    runner = doctest.DocTestRunner(optionflags=doctest.NORMALIZE_WHITESPACE)
    assert sum(len(t.examples) for t in tests) >= 4
    for test in tests:
        runner.run(test)
    assert runner.summarize(verbose=False).failed == 0


@pytest.mark.slow
def test_the_notebook_page_runs(fixture_run, tmp_path, monkeypatch, capsys):
    blocks = re.findall(r"```python\n(.*?)```", PAGE.read_text(encoding="utf-8"), re.S)
    assert len(blocks) == 3
    monkeypatch.chdir(tmp_path)  # the page writes runs/ where it runs
    namespace: dict = {}
    for block in blocks:
        exec(compile(block, str(PAGE), "exec"), namespace)
    first, both = namespace["first"], namespace["both"]
    assert first.run_dir == Path("runs/notebook-a")
    assert set(first.speedups["kernel"]) == {"moller_trumbore", "curless"} and len(first.speedups) == 4
    assert set(both.speedups["run"]) == {"A", "B"} and set(both.orders["order"]) <= {"holds", "differs", "undecided"}
    assert (tmp_path / "runs/notebook-b" / runfolder.GOOGLE_BENCHMARK).is_file()
    said = capsys.readouterr().err  # each sweep says how long it should take before it starts
    assert said.count("tribench.sweep: expected: about ") == 2 and "-> runs/notebook-b" in said


def test_results_hold_the_run_folders_tables(fixture_run):
    r = tribench.load(fixture_run)
    assert r.run_dir == fixture_run and set(r.tables) >= {runfolder.ESTIMATES, runfolder.RANKING}
    assert r.estimates is r.tables[runfolder.ESTIMATES] and list(r.ranking.columns) == list(
        runfolder.FILES[runfolder.RANKING]
    )


def test_mistakes_are_one_user_error(fixture_run, tmp_path):
    with pytest.raises(UserError, match="no_such_kernel"):
        tribench.sweep(["no_such_kernel"], [tribench.PairSpec(n=10, hit_rate=0.5)], out=tmp_path / "x")
    with pytest.raises(UserError, match="exists and is not empty"):
        tribench.sweep(["curless"], [tribench.PairSpec(n=10, hit_rate=0.5)], out=fixture_run)
    with pytest.raises(UserError, match="no run directory"):
        tribench.load(tmp_path / "nope")
    with pytest.raises(AttributeError):
        tribench.no_such_function  # noqa: B018


@pytest.mark.parametrize(
    ("call", "named"),
    [
        (lambda out: tribench.sweep(None, [tribench.PairSpec(n=10)], out=out), "kernels"),
        (lambda out: tribench.sweep("moller_trumbore", [tribench.PairSpec(n=10)], out=out), "kernels"),
        (lambda out: tribench.sweep(["moller_trumbore"], tribench.PairSpec(n=10), out=out), "workloads"),
        (lambda out: tribench.sweep(["moller_trumbore"], [tribench.PairSpec(n=10)], out=5), "out"),
        (
            lambda out: tribench.sweep(["moller_trumbore"], [tribench.PairSpec(n=10)], out=out, progress="no"),
            "progress",
        ),
        (lambda out: tribench.sweep(["moller_trumbore"], [tribench.PairSpec(n=10)], out="/etc/passwd"), "is a file"),
        (lambda out: tribench.run(out, quick="yes"), "quick"),
        (lambda out: tribench.load(3), "run_dir"),
        (lambda out: tribench.load(None), "run_dir"),
        (lambda out: tribench.compare(["a", "b"]), "separate arguments"),
    ],
)
def test_a_wrong_argument_is_one_user_error_naming_it(call, named, tmp_path):
    with pytest.raises(UserError, match=named) as info:
        call(tmp_path / "run")
    assert "\n" not in str(info.value) and not (tmp_path / "run").exists()  # refused before anything ran


def test_the_facade_imports_nothing_until_called():
    code = (
        "import sys, tribench.ext, tribench; assert callable(tribench.sweep); "
        "print(sorted(m for m in sys.modules if m.startswith('tribench.')))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True).stdout
    assert "tribench.harness" not in out and "tribench.reports" not in out and "tribench.ext" in out
