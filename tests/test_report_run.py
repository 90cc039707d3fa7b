"""One small real run, made once per test session, for every report test; and its CSV columns.

Other report test modules import :func:`run_fixture_dir` from here.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pandas as pd
import pytest

from tribench.harness import peers, records, runner, validate
from tribench.harness.plan import Sweep
from tribench.reports import columns
from tribench.workloads.spec import MeshSpec, PairSpec

KERNELS = ("moller_seed", "moller_trumbore", "curless")
WORKLOADS = (
    PairSpec(n=500, hit_rate=0.2),
    PairSpec(n=500, hit_rate=0.8),
    MeshSpec("suzanne", triangles=100, width=16, height=16),
    MeshSpec("suzanne", triangles=300, width=16, height=16),
)


def run_fixture_dir(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """``(run_dir, cache_dir)`` of the session's small run, made on first use.

    3 kernels x 4 workloads (pairs at two per-test hit rates, Suzanne at two
    triangle counts), 3 processes x 3 rounds (+1 warm-up), and its robustness
    table at validate's quick sizes (as ``tribench run`` writes it, smaller).
    The caller sets ``TRIBENCH_CACHE`` to ``cache_dir`` while it reads the run.
    """
    base = tmp_path_factory.getbasetemp() / "report-run"
    run_dir, cache = base / "run", base / "cache"
    if not (run_dir / "batches.csv").is_file():
        with pytest.MonkeyPatch.context() as mp:
            mp.setenv("TRIBENCH_CACHE", str(cache))
            sweep = Sweep(KERNELS, WORKLOADS, processes=3, rounds=3, warmup=1, target_ms=0.2, seed=5)
            runner.start(sweep, run_dir, progress=False)
        validate.run(KERNELS, ["float64"], quick=True).to_csv(run_dir / "validate.csv", index=False)
    return run_dir, cache


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    run_dir, cache = run_fixture_dir(tmp_path_factory)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("TRIBENCH_CACHE", str(cache))
        yield run_dir


def test_the_run_folder_csvs_have_exactly_the_documented_columns(small_run):
    from tribench import reports

    reports.write_report(small_run)  # makes estimates.csv and speedups.csv if missing
    for name, documented in columns.FILES.items():
        if name in columns.OPTIONAL:  # peers.csv: its own test, when a peer is installed
            continue
        header = list(pd.read_csv(small_run / name, nrows=0).columns)
        assert header == list(documented), f"{name}: columns changed; update reports/columns.py deliberately"


def test_documented_columns_match_the_harness_records():
    assert tuple(columns.BATCHES) == records.BATCH_COLUMNS
    assert tuple(columns.PROCESSES) == records.PROCESS_COLUMNS
    assert tuple(columns.CHECKS) == records.CHECK_COLUMNS
    assert list(columns.VALIDATE) == list(validate.COLUMNS)
    assert tuple(columns.PEERS) == peers.COLUMNS


def test_estimate_and_speedup_columns_say_their_unit():
    from tribench.harness import analysis

    # every renamed column is documented, and no bare statistic name is left in the files
    assert set(analysis.ESTIMATE_COLUMNS.values()) <= set(columns.ESTIMATES)
    assert set(analysis.SPEEDUP_COLUMNS.values()) <= set(columns.SPEEDUPS)
    for cols in (columns.ESTIMATES, columns.SPEEDUPS):
        assert not {"mean", "ci_low", "ci_high", "minimum", "sd", "n"} & set(cols)


def test_report_redoes_tables_written_in_old_columns(tmp_path_factory, monkeypatch):
    from tribench.reports.rundata import load_run

    run_dir, cache = run_fixture_dir(tmp_path_factory)
    monkeypatch.setenv("TRIBENCH_CACHE", str(cache))
    copy = tmp_path_factory.mktemp("old-columns") / "run"
    shutil.copytree(run_dir, copy)
    load_run(copy)  # makes the tables if the copy has none yet
    est = pd.read_csv(copy / "estimates.csv")
    est.rename(columns={"ns_per_test": "mean"}).to_csv(copy / "estimates.csv", index=False)
    assert load_run(copy).analysed_now  # as an older tribench wrote them: made again
    assert list(pd.read_csv(copy / "estimates.csv", nrows=0).columns) == list(columns.ESTIMATES)


def test_every_documented_column_has_a_description_and_snake_case_name():
    for name, cols in columns.FILES.items():
        for column, text in cols.items():
            assert column == column.lower() and " " not in column, (name, column)
            assert len(text) > 10, (name, column)


def test_report_computes_a_missing_robustness_table_once(tmp_path_factory, monkeypatch):
    from tribench.reports.rundata import load_run, load_validation

    run_dir, cache = run_fixture_dir(tmp_path_factory)
    monkeypatch.setenv("TRIBENCH_CACHE", str(cache))
    copy = tmp_path_factory.mktemp("no-validate") / "run"
    shutil.copytree(run_dir, copy)
    (copy / "validate.csv").unlink()
    data = load_run(copy)
    df, note = load_validation(data, quick=True)
    assert note.startswith("Computed now") and "quick sizes" in note
    assert list(pd.read_csv(copy / "validate.csv", nrows=0).columns) == list(columns.VALIDATE)
    assert len(df) == len(KERNELS) * len(validate.TESTS) and set(df["dtype"]) == {"float64"}
    assert list(dict.fromkeys(df["kernel"])) == list(data.kernels)  # in the run's order
    again, note = load_validation(data)
    assert note.startswith("Read from validate.csv") and again.equals(df)


def test_a_robustness_suite_that_cannot_run_does_not_stop_the_report(tmp_path_factory, monkeypatch):
    from tribench.reports.rundata import load_run, load_validation

    run_dir, cache = run_fixture_dir(tmp_path_factory)
    monkeypatch.setenv("TRIBENCH_CACHE", str(cache))
    copy = tmp_path_factory.mktemp("broken-validate") / "run"
    shutil.copytree(run_dir, copy)
    (copy / "validate.csv").unlink()

    def fail(*args, **kwargs):
        raise RuntimeError("no extension")

    monkeypatch.setattr(validate, "run", fail)
    df, note = load_validation(load_run(copy))
    assert df.empty and "could not run" in note and "no extension" in note
    assert not (copy / "validate.csv").exists()
