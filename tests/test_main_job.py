"""The main job (tribench.harness.jobs.main) and its tables: what the analysis returns is what it wrote."""

from __future__ import annotations

import dataclasses
import io
import json

import pandas as pd
import pytest

from tribench.harness import plan, runfolder
from tribench.harness.jobs import main as main_job
from tribench.harness.plan import Sweep
from tribench.reports import tables as analysis
from tribench.workloads.spec import MeshSpec, PairSpec

pytestmark = pytest.mark.slow  # the main job's small runs: CI runs it

#: The default sweep's shape (pairs at two hit rates, a mesh; the baseline and a clean kernel), as small as it goes.
TINY = Sweep(
    ("moller_seed", "moller_trumbore"),
    (
        PairSpec(n=256, hit_rate=0.2),
        PairSpec(n=256, hit_rate=0.8),
        MeshSpec("suzanne", triangles=100, width=8, height=8),
    ),
    processes=2,
    rounds=2,
    warmup=1,
    target_ms=0.2,
    rng_seed=3,
)


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    base = tmp_path_factory.mktemp("main-job")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("TRIBENCH_CACHE", str(base / "cache"))
        asked = []
        mp.setattr(plan, "default_sweep", lambda quick=False, kernel_files=(), builds=(): asked.append(quick) or TINY)
        log = io.StringIO()
        note = main_job.run(base / "run", quick=True, progress=False, peers=False, log=log)
    assert asked == [True]
    derived = analysis.write_all(base / "run", validate_note=note)
    return _Done(base / "run", derived.estimates, derived.speedups, derived.tables), log.getvalue()


@dataclasses.dataclass
class _Done:
    run_dir: object
    estimates: pd.DataFrame
    speedups: pd.DataFrame
    tables: dict


def _read(run_dir, name: str) -> pd.DataFrame:
    if name == runfolder.WORKLOAD_FIGURES:  # JSON text, read as written (as the report reads it)
        return pd.read_csv(run_dir / name, dtype=str, keep_default_na=False)
    return pd.read_csv(run_dir / name)


def _same(returned: pd.DataFrame, name: str, written: pd.DataFrame) -> None:
    assert list(returned.columns) == list(runfolder.FILES[name]), name
    # the values as written (floats round-trip through the CSV); a column of no rows reads back as text
    pd.testing.assert_frame_equal(
        returned.reset_index(drop=True), written, check_dtype=False, check_exact=True, obj=name
    )


def test_the_returned_frames_are_the_csvs_it_wrote(result):
    done, _ = result
    run_dir = done.run_dir
    _same(done.estimates, runfolder.ESTIMATES, _read(run_dir, runfolder.ESTIMATES))
    _same(done.speedups, runfolder.SPEEDUPS, _read(run_dir, runfolder.SPEEDUPS))
    assert set(done.estimates["kernel"]) == set(TINY.kernels) and len(done.estimates) == 2 * len(TINY.workloads)
    assert set(done.speedups["kernel"]) == {"moller_trumbore"} and set(done.speedups["baseline"]) == {"moller_seed"}
    for name, frame in done.tables.items():
        _same(frame, name, _read(run_dir, name))
    assert set(_read(run_dir, runfolder.VALIDATE)["kernel"]) == set(TINY.kernels)


def test_the_run_folder_holds_every_table_of_a_run_without_peers(result):
    done, log = result
    run_dir = done.run_dir
    for name, columns in runfolder.FILES.items():
        if name in runfolder.OPTIONAL:
            assert not (run_dir / name).exists(), name  # peers=False: no peers, no peer tables
            continue
        assert list(pd.read_csv(run_dir / name, nrows=0).columns) == list(columns), name
    assert set(done.tables) == set(runfolder.DERIVED) - {runfolder.VALIDATE} - runfolder.OPTIONAL
    record = json.loads((run_dir / runfolder.ANALYSIS).read_text(encoding="utf-8"))
    assert record["tables"] == list(done.tables) and record["peers_sha256"] is None
    pictures = list(record["pictures"].values())
    assert len(pictures) == len(TINY.workloads)
    assert all((run_dir / p).read_bytes().startswith(b"\x89PNG") for p in pictures)
    assert json.loads((run_dir / runfolder.RUN).read_text(encoding="utf-8"))["n_batches"] == TINY.n_batches
    assert not (run_dir / runfolder.PEERS).exists() and f"{TINY.n_batches} batches run in" in log
    assert "tribench run: moller_seed, moller_trumbore on 3 workloads" in log and "validate:" in log


@pytest.mark.parametrize("quick", [False, True])
def test_the_default_sweep_ranks_every_algorithm_in_its_best_form_against_the_seed(quick):
    from tribench import ext

    s = plan.default_sweep(quick=quick)
    info = {k: ext.kernel_info(k) for k in ext.kernel_names()}
    seed = {k for k, i in info.items() if i.seed_replay}
    native = {k for k, i in info.items() if i.lanes > 1}
    assert seed == {"curless_seed", "moller_seed"}
    by_kind = {}
    for spec in s.workloads:
        kind = "bvh" if getattr(spec, "accel", "brute") == "bvh" else spec.kind
        by_kind.setdefault(kind, []).append((spec, set(s.kernels_for(spec))))
    # the baseline's A/A twin wherever the baseline runs (the run's own margin), nowhere else
    for spec in s.workloads:
        assert ("moller_seed_aa" in s.kernels_for(spec)) == ("moller_seed" in s.kernels_for(spec))
    seed_and_twin = seed | {"moller_seed_aa"}
    # pairs: the seed's two and every scalar form, so every algorithm, at several hit rates
    for _, kernels in by_kind["pairs"]:
        kernels -= {"moller_seed_aa"}
        assert seed < kernels and {info[k].algorithm for k in kernels} == {i.algorithm for i in info.values()}
    assert len({spec.hit_rate for spec, _ in by_kind["pairs"]}) >= 3
    # brute-force meshes: the seed's two and every native form, in both precisions
    assert {spec.dtype for spec, _ in by_kind["mesh"]} == {"float32", "float64"}
    for _, kernels in by_kind["mesh"]:
        assert kernels == seed_and_twin | native
    assert {info[k].algorithm for k in native} == {i.algorithm for k, i in info.items() if not i.seed_replay}
    # one BVH workload, camera rays, float32, every native form as its leaf test
    ((bvh, kernels),) = by_kind["bvh"]
    assert kernels == native and (bvh.rays, bvh.dtype) == ("camera", "float32")
    assert bvh.triangles >= (10_000 if quick else 250_000)
    assert s.sequential is not None and s.sequential.budget_s <= (15 if quick else 300)
    # every public kernel
    assert set(s.kernels) == set(info) | {"moller_seed_aa"}


def test_an_interrupted_main_job_resumes_to_the_end(tmp_path, monkeypatch):
    from tribench.harness import runner

    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path / "cache"))
    out = tmp_path / "run"
    runner.start(TINY, out, progress=False, extra={"main_job": {"quick": True}})
    lines = (out / "batches.csv").read_text().splitlines(keepends=True)
    (out / "batches.csv").write_text("".join(lines[: len(lines) // 2]))  # the sweep stopped half-way
    log = io.StringIO()
    main_job.resume(out, progress=False, peers=False, log=log)
    assert len((out / "batches.csv").read_text().splitlines()) == len(lines)
    assert (out / runfolder.VALIDATE).is_file() and not (out / runfolder.ANALYSIS).exists()  # it measures only
    assert "finishing the main job" in log.getvalue()


# a sweep, then its refusal (seconds)
def test_resume_refuses_a_folder_that_is_not_a_main_job(tmp_path, monkeypatch):
    from tribench.common import UserError
    from tribench.harness import runner

    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path / "cache"))
    runner.start(TINY, tmp_path / "sweep", progress=False)
    with pytest.raises(UserError, match="not a main job's run folder.*tribench sweep --resume"):
        main_job.resume(tmp_path / "sweep", progress=False, peers=False)


def test_an_interrupt_inside_the_main_job_names_run_resume(tmp_path, monkeypatch):
    from tribench.harness.runner import SweepInterrupted

    def interrupted(sweep, out, **_):
        raise SweepInterrupted(
            f"interrupted: 3 of 9 batches saved in {out}; finish with: tribench sweep --resume {out}"
        )

    monkeypatch.setattr(main_job, "run_sweep", interrupted)
    monkeypatch.setattr(plan, "default_sweep", lambda quick=False, kernel_files=(), builds=(): TINY)
    with pytest.raises(SweepInterrupted, match=f"finish with: tribench run --resume {tmp_path}$"):
        main_job.run(tmp_path, quick=True, progress=False, peers=False, log=io.StringIO())


def test_run_resume_is_refused_in_one_line_where_it_cannot_apply(tmp_path):
    import subprocess
    import sys

    folder = tmp_path / "folder"
    folder.mkdir()
    for extra, said in (
        (["--quick"], "--resume takes neither --quick, --out, --kernel-file nor --builds"),
        ([], "not a run directory"),
    ):
        done = subprocess.run(
            [sys.executable, "-m", "tribench.cli", "run", "--resume", str(folder), *extra],
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert done.returncode == 2 and said in done.stderr and "Traceback" not in done.stderr, done.stderr


def test_the_baselines_a_a_twin_sets_the_margin_and_is_ranked_nowhere(tmp_path, monkeypatch):
    from tribench import reports
    from tribench.reports.tables import margin as twin

    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path / "cache"))
    sweep = dataclasses.replace(TINY, kernels=(*TINY.kernels, "moller_seed_aa"), processes=3)
    with monkeypatch.context() as mp:
        mp.setattr(plan, "default_sweep", lambda quick=False, kernel_files=(), builds=(): sweep)
        note = main_job.run(tmp_path / "run", quick=True, progress=False, peers=False, log=io.StringIO())
    done = analysis.write_all(tmp_path / "run", validate_note=note)
    # the twin is measured beside the baseline, and its A/A speedups are the margin
    assert "moller_seed_aa" in set(done.estimates["kernel"]) and "moller_seed_aa" in set(done.speedups["kernel"])
    expected = twin.twin_margin(done.tables[runfolder.PER_PROCESS], "moller_seed")
    assert expected is not None and expected.source.startswith("A/A twin in this run")
    assert (done.speedups["margin"] == expected.value).all()
    assert (done.speedups["margin_source"] == expected.source).all()
    # no ranking, kernel table or report row names it
    for name in (runfolder.RANKING, runfolder.BANDS, runfolder.ALGORITHMS, runfolder.KERNELS):
        assert "moller_seed_aa" not in set(done.tables[name].get("kernel", ())), name
    data = reports.load(tmp_path / "run")
    assert "moller_seed_aa" not in data.kernels and "moller_seed_aa" not in set(data.estimates["kernel"])
    # --margin still wins
    assert analysis.analyse(tmp_path / "run", margin=0.05).margin.source == "--margin"
