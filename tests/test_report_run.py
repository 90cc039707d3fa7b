"""One small real run, made once per test session, for every report test; and its CSV columns.

Other report test modules import :func:`run_fixture_dir` from here.
"""

from __future__ import annotations

import fcntl
import json
import os
import shutil
from pathlib import Path

import pandas as pd
import pytest
from conftest import analysed

from tribench.harness import runfolder, runner
from tribench.harness.jobs import peers, validate
from tribench.harness.plan import Sweep
from tribench.reports import tables as analysis
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
    triangle counts), 3 processes x 3 rounds (+1 warm-up), its robustness
    table at validate's quick sizes, then the analysis step (as ``tribench run``
    does, smaller). It is made once per session (:func:`_made_once`) and each
    pytest-xdist worker reads its own copy, which the report tests write into.
    The caller sets ``TRIBENCH_CACHE`` to ``cache_dir`` while it reads the run.
    """
    base = tmp_path_factory.getbasetemp() / "report-run"
    run_dir, cache = base / "run", base / "cache"
    if not (run_dir / "batches.csv").is_file():
        made = _made_once(tmp_path_factory)
        shutil.copytree(made / "cache", cache)
        shutil.copytree(made / "run", run_dir)
    return run_dir, cache


def _made_once(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The folder holding the session's small run (``run/``) and its cache (``cache/``).

    Under pytest-xdist the workers share their session's folder (the parent of
    each worker's own), and the first to get there makes the run while the
    others wait on a lock: it is about 9 s of work, not worth doing twice."""
    own = tmp_path_factory.getbasetemp()
    shared = own.parent if os.environ.get("PYTEST_XDIST_WORKER") else own
    made = shared / "report-run-made"
    with open(shared / "report-run.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (made / "done").is_file():
            shutil.rmtree(made, ignore_errors=True)  # a worker that died making it
            with pytest.MonkeyPatch.context() as mp:
                mp.setenv("TRIBENCH_CACHE", str(made / "cache"))
                sweep = Sweep(KERNELS, WORKLOADS, processes=3, rounds=3, warmup=1, target_ms=0.2, rng_seed=5)
                runner.start(sweep, made / "run", progress=False)
                validate.run(KERNELS, ["float64"], quick=True).to_csv(made / "run" / "validate.csv", index=False)
                analysed(made / "run")
            (made / "done").touch()
    return made


def copy_run_inputs(run_dir: Path, folder: Path, names=("run.json", "processes.csv", "validate.csv")) -> None:
    """Start a run folder made from ``run_dir``'s files ``names``, and its workload pictures.

    A picture is a pure function of its workload and the analysis keeps one it
    finds, so a run derived from the fixture's does not draw them again (1 s each)."""
    folder.mkdir(parents=True)
    for name in names:
        shutil.copy(run_dir / name, folder / name)
    shutil.copytree(run_dir / runfolder.PICTURES_DIR, folder / runfolder.PICTURES_DIR)


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    run_dir, cache = run_fixture_dir(tmp_path_factory)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("TRIBENCH_CACHE", str(cache))
        yield run_dir


def test_the_run_folder_csvs_have_exactly_the_documented_columns(small_run):
    for name, documented in runfolder.FILES.items():
        if name in runfolder.OPTIONAL:  # peers.csv: its own test, when a peer is installed
            continue
        header = list(pd.read_csv(small_run / name, nrows=0).columns)
        assert header == list(documented), f"{name}: columns changed; update harness/runfolder.py deliberately"


def test_the_analysis_writes_every_derived_table_and_lists_it(small_run):
    record = json.loads((small_run / runfolder.ANALYSIS).read_text())
    assert set(record["tables"]) == set(runfolder.DERIVED) - {runfolder.VALIDATE} - runfolder.OPTIONAL
    assert record["batches_sha256"] == analysis.file_digest(small_run / runfolder.BATCHES)
    wids = list(pd.read_csv(small_run / runfolder.WORKLOADS)["workload_id"])
    assert record["pictures"] == {w: f"pictures/{w}.png" for w in wids}
    assert all((small_run / p).read_bytes().startswith(b"\x89PNG") for p in record["pictures"].values())
    wl = pd.read_csv(small_run / runfolder.WORKLOADS).set_index("workload_id")
    pairs = wl.loc[wl["kind"] == "pairs"]  # the achieved per-test hit rates the crossover plots need
    assert sorted(pairs["test_hit_rate"]) == pytest.approx([0.2, 0.8], abs=0.01)
    cross = pd.read_csv(small_run / runfolder.CROSSOVERS)
    assert len(cross) == 3 and set(cross["family"]) == set(pairs["family"])  # every pair of the 3 kernels


def test_one_module_owns_the_names_and_columns():
    from tribench.harness.jobs import seed

    assert tuple(runfolder.FILES[runfolder.BATCHES]) == runfolder.BATCH_COLUMNS
    assert tuple(runfolder.FILES[runfolder.PROCESSES]) == runfolder.PROCESS_COLUMNS
    assert tuple(runfolder.FILES[runfolder.CHECKS]) == runfolder.CHECK_COLUMNS
    assert validate.COLUMNS is runfolder.FILES[runfolder.VALIDATE]
    assert tuple(runfolder.FILES[runfolder.PEERS]) == peers.COLUMNS and peers.PEERS == runfolder.PEERS
    assert seed.COLUMNS is runfolder.SEED_FILES
    assert runfolder.BATCHES == runfolder.BATCHES and analysis.ESTIMATES == runfolder.ESTIMATES


def test_estimate_and_speedup_columns_say_their_unit():
    # every renamed column is documented, and no bare statistic name is left in the files
    assert set(analysis.ESTIMATE_COLUMNS.values()) <= set(runfolder.FILES[runfolder.ESTIMATES])
    assert set(analysis.SPEEDUP_COLUMNS.values()) <= set(runfolder.FILES[runfolder.SPEEDUPS])
    for cols in (runfolder.FILES[runfolder.ESTIMATES], runfolder.FILES[runfolder.SPEEDUPS]):
        assert not {"mean", "ci_low", "ci_high", "minimum", "sd", "n"} & set(cols)


def test_every_documented_column_has_a_description_and_snake_case_name():
    for name, cols in {**runfolder.FILES, **runfolder.SEED_FILES}.items():
        for column, text in cols.items():
            assert column == column.lower() and " " not in column, (name, column)
            assert len(text) > 10, (name, column)


def _copy(tmp_path_factory, name: str) -> Path:
    run_dir, _ = run_fixture_dir(tmp_path_factory)
    copy = tmp_path_factory.mktemp(name) / "run"
    shutil.copytree(run_dir, copy)
    return copy


def test_report_refuses_tables_in_old_columns_and_names_tribench_stats(tmp_path_factory):
    from tribench.reports.rundata import RunError, load_run

    copy = _copy(tmp_path_factory, "old-columns")
    est = pd.read_csv(copy / "estimates.csv")
    est.rename(columns={"ns_per_test": "mean"}).to_csv(copy / "estimates.csv", index=False)
    with pytest.raises(RunError, match=r"estimates.csv is not in today's columns.*tribench stats"):
        load_run(copy)
    assert "mean" in pd.read_csv(copy / "estimates.csv", nrows=0).columns  # left as it was


@pytest.mark.parametrize(
    "change, message",
    [
        ("no-analysis", "no analysis tables"),
        ("batches-changed", "made from another batches.csv"),
        ("table-missing", "drift.csv is missing"),
        ("other-baseline", "compare against moller_seed, not curless"),
    ],
)
def test_report_refuses_missing_or_stale_tables(tmp_path_factory, change, message):
    from tribench.reports.rundata import RunError, load_run

    copy = _copy(tmp_path_factory, change)
    baseline = None
    if change == "no-analysis":
        (copy / runfolder.ANALYSIS).unlink()
    elif change == "batches-changed":  # a resumed run: one batch more than the tables saw
        lines = (copy / "batches.csv").read_text().splitlines(keepends=True)
        (copy / "batches.csv").write_text("".join(lines[:-1]))
    elif change == "table-missing":
        (copy / runfolder.DRIFT).unlink()
    else:
        baseline = "curless"
    with pytest.raises(RunError, match=message) as info:
        load_run(copy, baseline=baseline)
    assert f"tribench stats {copy}" in str(info.value)


def test_a_missing_robustness_table_is_named_with_its_command_and_the_sweep_path_makes_it(
    tmp_path_factory, monkeypatch, capsys
):
    from tribench.cli.command import main
    from tribench.reports.rundata import load_run, load_validation

    run_dir, cache = run_fixture_dir(tmp_path_factory)
    monkeypatch.setenv("TRIBENCH_CACHE", str(cache))
    copy = _copy(tmp_path_factory, "no-validate")
    (copy / "validate.csv").unlink()
    df, note = load_validation(load_run(copy))  # the report alone does not run the suite
    assert df.empty and f"--out {copy / 'validate.csv'}" in note and not (copy / "validate.csv").exists()
    assert main(["stats", str(copy)]) == 0
    assert "tribench validate --kernels " in capsys.readouterr().err
    assert not (copy / "validate.csv").exists()  # stats never measures
    analysed(copy, quick=True)
    data = load_run(copy)
    df, note = load_validation(data)
    assert note.startswith("Read from validate.csv") and "made by the robustness suite" in note
    assert list(pd.read_csv(copy / "validate.csv", nrows=0).columns) == list(runfolder.FILES[runfolder.VALIDATE])
    assert len(df) == len(KERNELS) * len(validate.TESTS) and set(df["dtype"]) == {"float64"}
    assert list(dict.fromkeys(df["kernel"])) == list(data.kernels)  # in the run's order


def test_a_robustness_suite_that_cannot_run_does_not_stop_the_analysis(tmp_path_factory, monkeypatch):
    from tribench.reports.rundata import load_run, load_validation

    run_dir, cache = run_fixture_dir(tmp_path_factory)
    monkeypatch.setenv("TRIBENCH_CACHE", str(cache))
    copy = _copy(tmp_path_factory, "broken-validate")
    (copy / "validate.csv").unlink()

    def fail(*args, **kwargs):
        raise RuntimeError("no extension")

    monkeypatch.setattr(validate, "run", fail)
    analysed(copy)
    df, note = load_validation(load_run(copy))
    assert df.empty and "could not run" in note and "no extension" in note
    assert not (copy / "validate.csv").exists()


def test_the_ranking_orders_every_workload_and_pairs_each_kernel_with_the_fastest(small_run):
    """ranking.csv, recomputed from per_process.csv and speedups.csv by hand."""
    import numpy as np

    from tribench import ext

    rank = pd.read_csv(small_run / runfolder.RANKING)
    pp = pd.read_csv(small_run / runfolder.PER_PROCESS)
    spd = pd.read_csv(small_run / runfolder.SPEEDUPS)
    est = pd.read_csv(small_run / runfolder.ESTIMATES)
    val = pd.read_csv(small_run / runfolder.VALIDATE)
    assert set(rank["workload_id"]) == set(est["workload_id"])
    # the sweep's own order (workloads.csv's), not the ids' hashes: hit rates read 0%, 50%, 100%
    planned = pd.read_csv(small_run / runfolder.WORKLOADS)["workload_id"]
    assert list(dict.fromkeys(rank["workload_id"])) == [w for w in planned if w in set(rank["workload_id"])]
    for wid, g in rank.groupby("workload_id"):
        assert list(g["rank"]) == list(range(1, len(g) + 1))
        assert g["ns_per_test"].is_monotonic_increasing
        assert set(g["kernel"]) == set(est.loc[est["workload_id"] == wid, "kernel"])
        fastest = g.iloc[0]
        assert (fastest["vs_fastest"], fastest["tied_with_fastest"]) == (1.0, True)
        per = pp.loc[pp["workload_id"] == wid].pivot(index="process", columns="kernel", values="ns_per_test")
        for r in g.iloc[1:].itertuples(index=False):
            want = np.exp(np.mean(np.log(per[r.kernel] / per[fastest["kernel"]])))
            assert r.vs_fastest == pytest.approx(want, rel=1e-12)
            assert r.vs_fastest_ci_low <= r.vs_fastest <= r.vs_fastest_ci_high
            assert r.tied_with_fastest == (
                r.vs_fastest_ci_low <= 1 + json.loads((small_run / "run.json").read_text())["margin"]["value"]
            )
        for r in g.itertuples(index=False):
            info = ext.kernel_info(r.kernel)
            assert (r.algorithm, r.watertight, r.culls_back_faces) == (
                info.algorithm,
                info.watertight != "none",
                info.culls_back_faces,
            )
            s = spd.loc[(spd["workload_id"] == wid) & (spd["kernel"] == r.kernel)]
            assert r.speedup == (s["ratio"].iloc[0] if len(s) else 1.0)
            # the kernel's measured robustness at the workload's precision (all float64 here, as validated)
            mine = val.loc[(val["kernel"] == r.kernel) & (val["dtype"] == r.dtype)].set_index("test")
            assert r.cracks_per_million == pytest.approx(1e6 * mine.loc["shared_edges", "rate"])
            assert r.sphere_misses_per_million == pytest.approx(1e6 * mine.loc["inside_sphere", "rate"])
            assert (r.shared_edge_rays, r.sphere_rays) == tuple(mine.loc[["shared_edges", "inside_sphere"], "rays"])


def test_the_algorithm_table_pairs_every_two_algorithms_the_faster_first(small_run):
    from tribench.harness import stats

    rank = pd.read_csv(small_run / runfolder.RANKING)
    alg = pd.read_csv(small_run / runfolder.ALGORITHMS)
    margin = json.loads((small_run / "run.json").read_text())["margin"]["value"]
    for wid, g in alg.groupby("workload_id"):
        r = rank.loc[rank["workload_id"] == wid]
        n = r["algorithm"].nunique()
        assert len(g) == n * (n - 1) // 2
        best = r.sort_values("rank").drop_duplicates("algorithm").set_index("algorithm")["rank"]
        for row in g.itertuples(index=False):
            assert best[row.algorithm] < best[row.other_algorithm]
            assert row.confidence == pytest.approx(1 - 0.05 / len(g))
            assert row.verdict == stats.verdict(row.ratio_ci_low, row.ratio_ci_high, margin)


def test_the_bands_table_ranks_kernels_per_precision_and_hit_rate_band(small_run):
    """bands.csv, recomputed by hand from per_process.csv, workloads.csv and validate.csv."""
    import numpy as np

    from tribench import ext
    from tribench.harness import stats
    from tribench.reports.tables.ranking import band_of

    bands = pd.read_csv(small_run / runfolder.BANDS)
    pp = pd.read_csv(small_run / runfolder.PER_PROCESS)
    wl = pd.read_csv(small_run / runfolder.WORKLOADS)
    val = pd.read_csv(small_run / runfolder.VALIDATE)
    margin = json.loads((small_run / "analysis.json").read_text())["margin"]["value"]
    wl["band"] = [band_of(k, h) for k, h in zip(wl["kind"], wl["test_hit_rate"], strict=True)]
    # the fixture: pairs at 20% and 80%, two meshes
    assert list(dict.fromkeys(bands["band"])) == [
        "pairs, hit rate 0–35%",
        "pairs, hit rate 65–100%",
        "meshes, brute force",
    ]
    for (dtype, band), g in bands.groupby(["dtype", "band"], sort=False):
        wids = list(wl.loc[(wl["band"] == band) & (wl["dtype"] == dtype), "workload_id"])
        assert (g["workloads"] == len(wids)).all()
        assert list(g["rank"]) == list(range(1, len(g) + 1)) and g["ns_per_test"].is_monotonic_increasing
        assert set(g["kernel"]) == set(KERNELS)
        sub = pp.loc[pp["workload_id"].isin(wids)]
        per = sub.assign(log=np.log(sub["ns_per_test"])).pivot_table(
            index="process", columns="kernel", values="log", aggfunc="mean"
        )
        per = np.exp(per)  # each process's geometric mean over the band's workloads
        level = stats.simultaneous_confidence(0.95, len(g) - 1)
        fastest = g.iloc[0]["kernel"]
        for r in g.itertuples(index=False):
            assert r.ns_per_test == pytest.approx(per[r.kernel].mean(), rel=1e-12)
            assert r.ns_per_test_ci_low < r.ns_per_test < r.ns_per_test_ci_high
            if r.kernel != fastest:
                s = stats.speedup(per[r.kernel], per[fastest], confidence=level)
                assert (r.vs_fastest, r.vs_fastest_ci_low, r.vs_fastest_ci_high) == pytest.approx(
                    (s.ratio, s.ci_low, s.ci_high), rel=1e-12
                )
                assert r.tied_with_fastest == (r.vs_fastest_ci_low <= 1 + margin)
            if r.kernel == "moller_seed":
                assert r.speedup == 1.0
            else:
                s = stats.speedup(per["moller_seed"], per[r.kernel], confidence=level)
                assert (r.speedup, r.speedup_ci_low, r.speedup_ci_high) == pytest.approx(
                    (s.ratio, s.ci_low, s.ci_high), rel=1e-12
                )
            info = ext.kernel_info(r.kernel)
            assert (r.watertight, r.bytes_per_triangle) == (
                info.watertight != "none",
                ext.bytes_per_triangle(r.kernel, dtype),
            )
            mine = val.loc[(val["kernel"] == r.kernel) & (val["dtype"] == dtype)]
            assert r.broken_promises == (mine["verdict"] == "fail").sum()
            assert r.promises_checked == (mine["verdict"] != "measured").sum()
            for test, per_million, rays in (
                ("shared_edges", r.cracks_per_million, r.shared_edge_rays),
                ("inside_sphere", r.sphere_misses_per_million, r.sphere_rays),
            ):
                row = mine.loc[mine["test"] == test].iloc[0]
                assert per_million == pytest.approx(1e6 * row["rate"]) and rays == row["rays"]
    # a band of one workload is that workload's estimate
    est = pd.read_csv(small_run / runfolder.ESTIMATES).merge(wl, on="workload_id")
    one = est.loc[est["band"] == "pairs, hit rate 0–35%"].set_index("kernel")["ns_per_test"]
    low = bands.loc[bands["band"] == "pairs, hit rate 0–35%"].set_index("kernel")["ns_per_test"]
    assert low.to_dict() == pytest.approx(one.to_dict(), rel=1e-12)
