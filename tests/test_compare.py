"""`tribench compare`: ratio of speedups of two runs, with a known answer and Welch intervals."""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import analysed
from test_report_run import copy_run_inputs, run_fixture_dir

from tribench import cli, reports
from tribench.common import UserError
from tribench.harness.stats import unpaired_ratio
from tribench.reports import charts, page
from tribench.reports.compare import RATIO_WORDS, compare_many, compare_runs, format_many, order_summary, render_compare
from tribench.reports.rundata import load_run

pytestmark = pytest.mark.slow  # small runs measured, then compared: CI runs it

FACTOR = 1.25  # run B: moller_trumbore made exactly this much faster


def _steadied(batches: pd.DataFrame) -> pd.DataFrame:
    """``batches`` with each batch's time set to its kernel's median time per test on its workload, times a
    fixed jitter of at most 0.4%: a measured run's noise (±30% on a shared CI machine) can widen an interval
    past a factor of 1.25, and the known answers below must not depend on the machine's load."""
    per_test = batches["elapsed_ns"] / batches["tests"]
    median = per_test.groupby([batches["kernel"], batches["workload_id"]]).transform("median")
    jitter = 1 + 0.002 * (batches["position"] % 5 - 2)
    return batches.assign(elapsed_ns=(median * batches["tests"] * jitter).round().astype("int64"))


@contextlib.contextmanager
def steadied_pair(tmp_path_factory, kernel: str, factor: float):
    """Two analysed copies of the session's run, steadied (:func:`_steadied`), ``kernel`` made exactly
    ``factor`` times faster in the second; ``TRIBENCH_CACHE`` is the run's cache while they are used."""
    measured, cache = run_fixture_dir(tmp_path_factory)
    folder = tmp_path_factory.mktemp("pair")
    run_a, run_b = folder / "run_a", folder / "run_b"
    a = _steadied(pd.read_csv(measured / "batches.csv"))
    b = a.copy()
    faster = b["kernel"] == kernel
    b.loc[faster, "elapsed_ns"] = (b.loc[faster, "elapsed_ns"] / factor).round().astype("int64")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("TRIBENCH_CACHE", str(cache))
        for run, batches in ((run_a, a), (run_b, b)):
            copy_run_inputs(measured, run)
            batches.to_csv(run / "batches.csv", index=False)
            analysed(run)  # `tribench stats`: compare reads the tables, as the report does
        yield run_a, run_b


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory):
    with steadied_pair(tmp_path_factory, "moller_trumbore", FACTOR) as runs:
        yield runs


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


# the command in a fresh interpreter (seconds)
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
    assert 'id="speedup-ratios"' in text and text.count(charts.library()) == 1  # the charts' library, once
    text = text.replace(charts.library(), "")
    assert re.findall(r"<style>(.*?)</style>", text, re.S) == [page.CSS]  # the report's stylesheet, written once
    assert re.search(r"moller_trumbore\s+[\d.]+\s+[\d.]+\s+[\d.]+\s+\[[\d.]+, [\d.]+\]\s+\S", proc.stdout)
    assert "http://" not in text and "https://" not in text and "src=" not in text
    # the report's forest chart draws the ratio of speedups, its verdicts in the words of a ratio of two runs
    spec = json.loads(re.search(r'vegaEmbed\("#chart-forest",(\{.*?\}),\{actions', text).group(1))
    rows = [r for values in spec["datasets"].values() for r in values if r.get("kernel") == "moller_trumbore"]
    assert len(rows) == 4 and np.allclose([r["ratio"] for r in rows], FACTOR, rtol=1e-4)
    assert {r["verdict"] for r in rows} <= set(RATIO_WORDS.values()) and "larger on B" in {r["verdict"] for r in rows}
    flat = json.dumps(spec)
    assert json.dumps(list(RATIO_WORDS.values())) in flat and '"title": "equivalence margin"' in flat


def test_fail_if_slower_names_the_kernel_that_became_slower(two_runs, tmp_path, capsys):
    def gate(*runs):  # in this process: the command's exit code and its stderr
        code = cli.main(["compare", *map(str, runs), "--fail-if-slower", "--out", str(tmp_path / "c.html")])
        return code, capsys.readouterr().err

    a, b = two_runs  # b: moller_trumbore 1.25x faster, every other kernel's times the same to the bit
    assert gate(a, b)[0] == 0  # faster, or no change (an A/A pair): the gate passes
    code, err = gate(b, a)  # from b to a: moller_trumbore takes 1.25x the time
    assert code == 1, err
    lines = [line for line in err.splitlines() if line.startswith("slower in ")]
    assert lines and all(" moller_trumbore on " in line and "1.250x the time" in line for line in lines)
    code, err = gate(a, b, a)
    assert code == 2 and "--fail-if-slower compares two runs" in err


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


# ------------------------------------------------------------------ N runs

#: Each kernel's time as a fraction of moller_seed's, per faked machine: on "machine C"
#: curless overtakes moller_trumbore, every other order of two kernels is the same.
FACTORS = {
    "A": {"moller_trumbore": 0.5, "curless": 0.8},
    "B": {"moller_trumbore": 0.4, "curless": 0.7},
    "C": {"moller_trumbore": 0.5, "curless": 0.25},
}


def _fake_run(real: Path, folder: Path, factors: dict[str, float], cpu_model: str) -> Path:
    """A copy of a real run with each kernel's batch times set to moller_seed's in the same round
    times a known factor (with a 0.2% wobble between processes), and another CPU in run.json."""
    copy_run_inputs(real, folder, ("processes.csv", "validate.csv"))
    run = json.loads((real / "run.json").read_text())
    run["machine"]["cpu_model"] = cpu_model
    (folder / "run.json").write_text(json.dumps(run))
    b = pd.read_csv(real / "batches.csv")
    key = ["process", "round", "workload_id"]
    base = (
        b.loc[b["kernel"] == "moller_seed"].set_index(key)["elapsed_ns"]
        / b.loc[b["kernel"] == "moller_seed"].set_index(key)["tests"]
    )
    per_test = base.reindex(pd.MultiIndex.from_frame(b[key])).to_numpy()
    factor = b["kernel"].map(factors).fillna(1.0) * np.where(
        b["kernel"] == "moller_seed", 1, 1 + 0.002 * (b["process"] % 3)
    )
    b["elapsed_ns"] = (per_test * factor * b["tests"]).round().astype("int64")
    b.to_csv(folder / "batches.csv", index=False)
    analysed(folder)
    return folder


@pytest.fixture(scope="module")
def three_runs(tmp_path_factory):
    real, cache = run_fixture_dir(tmp_path_factory)
    base = tmp_path_factory.mktemp("three")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("TRIBENCH_CACHE", str(cache))
        yield [_fake_run(real, base / tag, f, f"machine {tag}") for tag, f in FACTORS.items()]


def test_n_runs_give_a_machine_by_kernel_table_of_known_speedups(three_runs):
    m = compare_many([load_run(r) for r in three_runs])
    assert m.tags == ["A", "B", "C"] and m.baseline == "moller_seed" and len(m.workload_ids) == 4
    s = m.speedups.set_index(["run", "workload_id", "kernel"])
    for tag, factors in FACTORS.items():
        for wid in m.workload_ids:
            assert s.loc[(tag, wid, "moller_seed"), "ratio"] == 1.0
            for kernel, f in factors.items():
                r = s.loc[(tag, wid, kernel)]
                assert r["ratio"] == pytest.approx(1 / f, rel=0.01)
                assert r["ratio_ci_low"] <= r["ratio"] <= r["ratio_ci_high"] and r["verdict"] == "faster"


def test_n_runs_say_which_orders_hold_on_every_machine(three_runs):
    m = compare_many([load_run(r) for r in three_runs])
    o = m.orders
    assert len(o) == 4 * 3  # every pair of the 3 kernels on every workload
    pair = {frozenset((r.kernel, r.other_kernel)): r.order for r in o.itertuples()}
    assert pair[frozenset(("moller_trumbore", "moller_seed"))] == "holds"
    assert pair[frozenset(("curless", "moller_seed"))] == "holds"
    assert pair[frozenset(("moller_trumbore", "curless"))] == "differs"
    flips = o.loc[o["order"] == "differs"]
    assert (flips["kernel"] == "moller_trumbore").all()  # oriented by run A, where it is the faster
    assert flips["ratio_C"].lt(1).all() and flips["ratio_A"].gt(1).all()
    assert (o.loc[o["order"] == "holds", ["verdict_A", "verdict_B", "verdict_C"]] == "faster").all().all()
    summary = order_summary(m).set_index(["kernel", "other_kernel"])  # over the 4 workloads, in sweep order
    assert summary.loc[("moller_seed", "moller_trumbore")].tolist() == [0, 4, 0, 0]
    assert summary.loc[("moller_seed", "curless")].tolist() == [0, 4, 0, 0]
    assert summary.loc[("moller_trumbore", "curless")].tolist() == [0, 0, 4, 0]


def test_a_workload_without_the_baseline_still_shows_its_orders(three_runs):
    # a BVH workload runs only native kernels, so the seed's baseline has no speedups there
    runs = [load_run(r) for r in three_runs]
    m = compare_many(runs)
    bvh_like = m.workload_ids[0]
    m = dataclasses.replace(m, speedups=m.speedups.loc[m.speedups["workload_id"] != bvh_like])
    text = format_many(runs, m)
    part = text.split(f"[{bvh_like}]")[1].split("\n\n")[0]
    assert "no speedups: moller_seed did not run" in part and "holds on every machine: moller_trumbore" in part
    assert f'{bvh_like})</small></h3><p class="note">(none)</p>' in render_compare(runs, m)


def test_compare_cli_takes_three_runs(three_runs, tmp_path):
    out = tmp_path / "three.html"
    proc = subprocess.run(
        [sys.executable, "-m", "tribench.cli", "compare", *map(str, three_runs), "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert "machine A" in proc.stdout and "machine C" in proc.stdout and "B/A" not in proc.stdout
    assert re.search(r"moller_trumbore\s+(2|1\.99)\d*× \[[\d.]+, [\d.]+\]\s+2\.[45]\d*× \[", proc.stdout)
    assert "holds on every machine: moller_trumbore faster than moller_seed" in proc.stdout
    assert "differs between machines: moller_trumbore faster than curless" in proc.stdout
    text = out.read_text()
    assert 'id="speedups"' in text and 'id="orders"' in text and 'id="machines"' in text
    assert 'id="speedup-ratios"' not in text  # the ratio of speedups is a two-run figure
    assert "http://" not in text and "https://" not in text and "<script" not in text  # no chart, no library
    assert text.count("speedup on C (×)") == 4  # a machine x kernel table per workload


def test_compare_of_two_runs_has_both_views(two_runs):
    text = reports.format_compare(*two_runs)
    assert "B/A" in text and "holds on every machine" in text


@pytest.mark.parametrize("count", [1, 27])
def test_compare_cli_refuses_fewer_than_two_or_more_than_26_runs(three_runs, count):
    runs = [str(three_runs[i % 3]) for i in range(count)]
    proc = subprocess.run(
        [sys.executable, "-m", "tribench.cli", "compare", *runs], capture_output=True, text=True, timeout=60
    )
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1 and "2 to 26 run folders" in proc.stderr


def test_compare_refuses_runs_with_different_baselines(three_runs, tmp_path):
    other = tmp_path / "other"
    shutil.copytree(three_runs[2], other)
    analysed(other, baseline="curless")
    with pytest.raises(UserError, match="different baselines .*C: curless"):
        compare_many([load_run(r) for r in [*three_runs[:2], other]])


# ------------------------------------------------------------- the statistic


def test_unpaired_ratio_matches_scipy_welch_t_test():
    from scipy import stats as sps

    rng = np.random.default_rng(3)
    a, b = rng.normal(0.1, 0.05, 7), rng.normal(0.3, 0.1, 12)
    r = unpaired_ratio(a, b)
    t = sps.ttest_ind(b, a, equal_var=False)
    assert math.isclose(r.p_value, t.pvalue, rel_tol=1e-9)
    assert math.isclose(math.log(r.ratio), b.mean() - a.mean(), rel_tol=1e-12)
    half = (math.log(r.ci_high) - math.log(r.ci_low)) / 2
    assert math.isclose(half, sps.t.ppf(0.975, r.df) * r.se, rel_tol=1e-9)


def test_unpaired_ratio_covers_the_true_ratio_about_95_percent():
    rng = np.random.default_rng(11)
    true = math.log(1.2)
    covered = 0
    for _ in range(2000):
        a = rng.normal(0.0, 0.03, 10)
        b = rng.normal(true, 0.08, 6)
        r = unpaired_ratio(a, b)
        covered += r.ci_low <= 1.2 <= r.ci_high
    assert 0.93 <= covered / 2000 <= 0.97


def test_unpaired_ratio_edge_cases():
    one = unpaired_ratio([0.0], [0.1, 0.2])
    assert math.isnan(one.ci_low) and math.isclose(one.ratio, math.exp(0.15))
    flat = unpaired_ratio([0.1, 0.1], [0.1, 0.1])
    assert flat.ratio == flat.ci_low == flat.ci_high == 1.0
    with pytest.raises(ValueError):
        unpaired_ratio([], [0.1])
    with pytest.raises(ValueError):
        unpaired_ratio([0.1, np.nan], [0.1, 0.2])


@pytest.fixture(scope="module")
def runs_sharing_only_the_baseline(two_runs, tmp_path_factory):
    """Run A with only moller_seed and curless, run B with only moller_seed and moller_trumbore."""
    run_a, _ = two_runs
    _, cache = run_fixture_dir(tmp_path_factory)
    folders = []
    for name, kept in (("only_curless", "curless"), ("only_mt", "moller_trumbore")):
        folder = tmp_path_factory.mktemp("shared-baseline") / name
        copy_run_inputs(run_a, folder)
        b = pd.read_csv(run_a / "batches.csv")
        b.loc[b["kernel"].isin(["moller_seed", kept])].to_csv(folder / "batches.csv", index=False)
        with pytest.MonkeyPatch.context() as mp:
            mp.setenv("TRIBENCH_CACHE", str(cache))
            analysed(folder)
        folders.append(folder)
    return folders


def test_runs_sharing_only_the_baseline_give_tables_of_what_they_share(runs_sharing_only_the_baseline, tmp_path):
    runs = [load_run(r) for r in runs_sharing_only_the_baseline]
    many = compare_many(runs)
    assert many.kernels == ["moller_seed"] and many.orders.empty and "workload_id" in many.orders.columns
    assert set(many.speedups["kernel"]) == {"moller_seed"}
    text = format_many(runs, many)
    assert "no order of two kernels" in text
    pair = compare_runs(*runs)
    assert pair.speedups.empty and set(pair.times["kernel"]) == {"moller_seed"}
    out = tmp_path / "compare.html"
    done = subprocess.run(
        [sys.executable, "-m", "tribench.cli", "compare", *map(str, runs_sharing_only_the_baseline), "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr and out.stat().st_size > 0


def test_a_run_given_twice_is_refused(two_runs):
    a = load_run(two_runs[0])
    with pytest.raises(UserError, match="given twice"):
        compare_many([a, load_run(two_runs[0])])
    done = subprocess.run(
        [sys.executable, "-m", "tribench.cli", "compare", str(two_runs[0]), str(two_runs[0])],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2 and "given twice" in done.stderr and "Traceback" not in done.stderr


# ------------------------------------------------------------------ equal work


def _with_answers_that_differ(run: Path, folder: Path, kernel: str, wid: str) -> Path:
    """A copy of an analysed run whose correctness.csv says ``kernel``'s answers differ on ``wid``."""
    shutil.copytree(run, folder)
    correct = pd.read_csv(folder / "correctness.csv")
    correct.loc[(correct["kernel"] == kernel) & (correct["workload_id"] == wid), "agrees"] = False
    correct.to_csv(folder / "correctness.csv", index=False)
    return folder


def test_a_kernel_whose_answers_differ_is_in_no_order_of_a_comparison(three_runs, tmp_path):
    wid = load_run(three_runs[0]).workload_ids[0]
    runs = [load_run(r) for r in three_runs[:2]]
    assert {"curless"} <= set(compare_many(runs).orders.query("workload_id == @wid")["kernel"])  # else no test
    differing = _with_answers_that_differ(three_runs[1], tmp_path / "B", "curless", wid)
    m = compare_many([runs[0], load_run(differing)])
    on_wid = m.orders.loc[m.orders["workload_id"] == wid]
    assert len(on_wid) == 1 and "curless" not in {*on_wid["kernel"], *on_wid["other_kernel"]}
    others = m.orders.loc[m.orders["workload_id"] != wid]
    assert len(others) == 3 * 3  # curless is still ordered where its answers agree
    pair = compare_runs(runs[0], load_run(differing))
    assert (wid, "curless") not in set(zip(pair.times["workload_id"], pair.times["kernel"], strict=True))


def test_a_comparison_where_the_baseline_is_missing_keeps_the_times(three_runs, tmp_path):
    # as on a BVH workload, where the seed's baseline does not run
    wid = load_run(three_runs[0]).workload_ids[0]
    differing = _with_answers_that_differ(three_runs[1], tmp_path / "B", "moller_seed", wid)
    pair = compare_runs(load_run(three_runs[0]), load_run(differing))
    assert wid not in set(pair.speedups["workload_id"]) and len(set(pair.speedups["workload_id"])) == 3
    assert set(pair.times.loc[pair.times["workload_id"] == wid, "kernel"]) == {"moller_trumbore", "curless"}


def test_the_comparisons_tables_name_each_workload_by_family_and_label(two_runs, tmp_path):
    """compare.html's ratio tables named a workload by its label alone: two runs with a hit rate at both
    precisions showed two rows per kernel that said the same. Each names its family too."""
    import html

    text = html.unescape(reports.write_compare(*two_runs, out=tmp_path / "cmp.html").read_text())
    wl = pd.read_csv(two_runs[0] / "workloads.csv")
    names = {f"{f} · {lab}" for f, lab in zip(wl["family"], wl["label"], strict=True)}
    for sid in ("speedup-ratios", "time-ratios", "orders"):
        part = text[text.index(f'id="{sid}"') :]
        for table in re.findall(r"<table.*?</table>", part[: part.index("</section>")], flags=re.S):
            rows = [re.findall(r"<t[dh][^>]*>([^<]*)</t[dh]>", row) for row in re.findall(r"<tr>(.*?)</tr>", table)]
            if "workload" in rows[0]:
                cells = {r[rows[0].index("workload")] for r in rows[1:]}
                assert cells and cells <= names, (sid, cells - names)
