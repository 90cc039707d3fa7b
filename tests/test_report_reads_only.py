"""`tribench report` only reads: a run folder copied to a machine with an empty workload cache renders the same
page, and no timing, workload generation, robustness suite, statistic or table write runs while it renders."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from test_report_run import run_fixture_dir

from tribench import ext, reports
from tribench.harness import runfolder, stats
from tribench.harness.jobs import sweep, validate
from tribench.reports import tables as analysis
from tribench.reports.tables import pipeline
from tribench.workloads import cache

pytestmark = pytest.mark.slow  # small runs measured, then reported: CI runs it

#: Every entry point that measures, makes a workload, runs the suite, computes a statistic or writes a table.
POISONED = [
    (ext, "time_batch"),
    (ext, "make_job"),
    (cache, "make"),
    (cache, "generate"),
    (cache, "load"),
    (validate, "run"),
    (sweep, "measure_robustness"),
    (analysis, "analyse"),
    (analysis, "write_all"),
    (analysis, "write_tables"),
    (pipeline, "analyse"),
    (pipeline, "write_all"),
    (pipeline, "write_tables"),
    (runfolder, "write_csv"),
    (stats, "per_process"),
    (stats, "estimate_table"),
    (stats, "speedup_table"),
    (stats, "crossover"),
    (stats, "scaling_slope"),
    (stats, "drift"),
    (stats, "variance_components"),
    (stats, "label_outliers"),
]


def _poison(monkeypatch: pytest.MonkeyPatch) -> None:
    for module, name in POISONED:

        def refuse(*args, _name=f"{module.__name__}.{name}", **kwargs):
            raise AssertionError(f"the report called {_name}")

        monkeypatch.setattr(module, name, refuse)


def _comparable(page: str, run_dir: Path) -> str:
    """The page without what legitimately differs between two renders: the folder's path and the time."""
    page = page.replace(str(run_dir), "RUN_DIR")
    return re.sub(r"Written by tribench report at \S+", "Written by tribench report at TIME", page)


def _files(folder: Path) -> list[Path]:
    return sorted(p for p in folder.rglob("*") if p.is_file())


@pytest.fixture(scope="module")
def copied(tmp_path_factory):
    """The session's run, rendered where it was made, and a copy of it (without its report) elsewhere."""
    run_dir, cache_dir = run_fixture_dir(tmp_path_factory)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("TRIBENCH_CACHE", str(cache_dir))
        original = reports.write_report(run_dir).read_text(encoding="utf-8")
    copy = tmp_path_factory.mktemp("elsewhere") / "run"
    shutil.copytree(run_dir, copy, ignore=shutil.ignore_patterns("report.html", "sweep.toml", "figures", ".lock"))
    return run_dir, original, copy


# two reports of a copied run (seconds)
def test_a_copied_run_renders_the_same_report_with_an_empty_cache_and_nothing_computed(copied, tmp_path, monkeypatch):
    run_dir, original, copy = copied
    empty = tmp_path / "empty-cache"
    empty.mkdir()
    monkeypatch.setenv("TRIBENCH_CACHE", str(empty))
    before = {p: p.read_bytes() for p in _files(copy)}
    _poison(monkeypatch)
    page = reports.write_report(copy).read_text(encoding="utf-8")
    assert _comparable(page, copy) == _comparable(original, run_dir)
    assert _files(empty) == []  # no workload generated
    after = _files(copy)
    figures = _files(copy / "figures")
    assert sorted(set(after) - set(before)) == sorted([copy / "report.html", copy / "sweep.toml", *figures])
    svgs = [f for f in figures if f.suffix == ".svg"]  # the PDF writer orders its objects differently per process
    assert svgs and all(f.read_bytes() == (run_dir / "figures" / f.name).read_bytes() for f in svgs)
    assert all(p.read_bytes() == data for p, data in before.items())  # no table rewritten
    assert reports.format_tables(copy) == reports.format_tables(run_dir).replace(str(run_dir), str(copy))


def test_the_report_command_on_a_copied_run_creates_no_cache_file(copied, tmp_path):
    run_dir, _, copy = copied
    empty = tmp_path / "cache"
    proc = subprocess.run(
        [sys.executable, "-m", "tribench.cli", "report", str(copy), "--quiet"],
        capture_output=True,
        text=True,
        timeout=300,
        env={**__import__("os").environ, "TRIBENCH_CACHE": str(empty)},
    )
    assert proc.returncode == 0, proc.stderr
    assert not empty.exists() or _files(empty) == []


def test_a_folder_without_tables_is_refused_in_one_line_naming_tribench_stats(copied, tmp_path):
    _, _, copy = copied
    bare = tmp_path / "bare"
    bare.mkdir()
    for name in ("run.json", "batches.csv", "processes.csv", "checks.csv"):
        shutil.copy(copy / name, bare / name)
    proc = subprocess.run(
        [sys.executable, "-m", "tribench.cli", "report", str(bare)], capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and f"tribench stats {bare}" in lines[0]
    assert sorted(p.name for p in bare.iterdir()) == ["batches.csv", "checks.csv", "processes.csv", "run.json"]
