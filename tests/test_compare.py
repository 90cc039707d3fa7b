"""`tribench compare`: ratio of speedups of two runs, with a known answer and Welch intervals."""

from __future__ import annotations

import math
import re
import shutil
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
from test_report_run import run_fixture_dir

from tribench import reports
from tribench.harness import analysis
from tribench.reports import page
from tribench.reports.compare import compare_runs
from tribench.reports.rundata import load_run
from tribench.stats import unpaired_ratio

FACTOR = 1.25  # run B: moller_trumbore made exactly this much faster


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory):
    run_a, cache = run_fixture_dir(tmp_path_factory)
    run_b = tmp_path_factory.mktemp("compare") / "run_b"
    run_b.mkdir()
    for name in ("run.json", "processes.csv", "validate.csv"):
        shutil.copy(run_a / name, run_b / name)
    b = pd.read_csv(run_a / "batches.csv")
    faster = b["kernel"] == "moller_trumbore"
    b.loc[faster, "elapsed_ns"] = (b.loc[faster, "elapsed_ns"] / FACTOR).round().astype("int64")
    b.to_csv(run_b / "batches.csv", index=False)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("TRIBENCH_CACHE", str(cache))
        analysis.write_all(run_b)  # `tribench stats`: compare reads the tables, as the report does
        yield run_a, run_b


def test_ratio_of_speedups_recovers_a_known_factor(two_runs):
    a, b = (load_run(r) for r in two_runs)
    c = compare_runs(a, b)
    mt = c.speedups.loc[c.speedups["kernel"] == "moller_trumbore"]
    assert len(mt) == 4 and np.allclose(mt["ratio"], FACTOR, rtol=1e-4)
    others = c.speedups.loc[c.speedups["kernel"] != "moller_trumbore"]
    assert np.allclose(others["ratio"], 1.0, rtol=1e-9)
    assert (c.speedups["ratio_ci_low"] <= c.speedups["ratio"]).all()
    assert (c.speedups["ratio"] <= c.speedups["ratio_ci_high"]).all()
    times = c.times.set_index(["kernel", "workload_id"])["ratio"]
    assert np.allclose(times.loc["moller_trumbore"], 1 / FACTOR, rtol=1e-4)
    assert c.only_a == [] and c.only_b == []


def test_compare_cli_prints_a_table_and_writes_html(two_runs, tmp_path):
    out = tmp_path / "cmp.html"
    proc = subprocess.run(
        [sys.executable, "-m", "tribench.cli", "compare", str(two_runs[0]), str(two_runs[1]), "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert "B/A" in proc.stdout and f"{FACTOR:.3f}" in proc.stdout
    text = out.read_text()
    assert 'id="speedup-ratios"' in text and "data:image/svg+xml;base64," in text
    assert re.findall(r"<style>(.*?)</style>", text, re.S) == [page.CSS]  # the report's stylesheet, written once
    assert re.search(r"moller_trumbore\s+[\d.]+\s+[\d.]+\s+[\d.]+\s+\[[\d.]+, [\d.]+\]\s+\S", proc.stdout)
    assert "http://" not in text and "https://" not in text and "<script" not in text


def test_write_compare_default_path(two_runs):
    path = reports.write_compare(*two_runs, out=None)
    assert path == two_runs[1] / "compare.html" and path.stat().st_size > 1000
    assert "moller_trumbore" in reports.format_compare(*two_runs)


def test_compare_refuses_runs_without_shared_workloads(two_runs, tmp_path):
    other = tmp_path / "other"
    shutil.copytree(two_runs[1], other)
    b = pd.read_csv(other / "batches.csv")
    b["workload_id"] = "pairs-000000000000"
    b.to_csv(other / "batches.csv", index=False)
    with pytest.raises((ValueError, reports.RunError)):
        compare_runs(load_run(two_runs[0]), load_run(other))


def test_compare_cli_missing_run_exits_2(tmp_path, two_runs):
    proc = subprocess.run(
        [sys.executable, "-m", "tribench.cli", "compare", str(two_runs[0]), str(tmp_path / "nope")],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1 and "no run directory" in proc.stderr


# ------------------------------------------------------------- the statistic


def testunpaired_ratio_matches_scipy_welch_t_test():
    from scipy import stats as sps

    rng = np.random.default_rng(3)
    a, b = rng.normal(0.1, 0.05, 7), rng.normal(0.3, 0.1, 12)
    r = unpaired_ratio(a, b)
    t = sps.ttest_ind(b, a, equal_var=False)
    assert math.isclose(r.p_value, t.pvalue, rel_tol=1e-9)
    assert math.isclose(math.log(r.ratio), b.mean() - a.mean(), rel_tol=1e-12)
    half = (math.log(r.ci_high) - math.log(r.ci_low)) / 2
    assert math.isclose(half, sps.t.ppf(0.975, r.df) * r.se, rel_tol=1e-9)


def testunpaired_ratio_covers_the_true_ratio_about_95_percent():
    rng = np.random.default_rng(11)
    true = math.log(1.2)
    covered = 0
    for _ in range(2000):
        a = rng.normal(0.0, 0.03, 10)
        b = rng.normal(true, 0.08, 6)
        r = unpaired_ratio(a, b)
        covered += r.ci_low <= 1.2 <= r.ci_high
    assert 0.93 <= covered / 2000 <= 0.97


def testunpaired_ratio_edge_cases():
    one = unpaired_ratio([0.0], [0.1, 0.2])
    assert math.isnan(one.ci_low) and math.isclose(one.ratio, math.exp(0.15))
    flat = unpaired_ratio([0.1, 0.1], [0.1, 0.1])
    assert flat.ratio == flat.ci_low == flat.ci_high == 1.0
    with pytest.raises(ValueError):
        unpaired_ratio([], [0.1])
    with pytest.raises(ValueError):
        unpaired_ratio([0.1, np.nan], [0.1, 0.2])
