"""Sequential sweeps (plan.Sequential, harness/stages.py): stages of processes, each comparison
stopped once its interval is narrow, recorded in stages.json, resumed as decided."""

from __future__ import annotations

import json
import shutil

import pandas as pd
import pytest
from conftest import analysed

from tribench.common import UserError
from tribench.harness import runfolder, runner, stages, stats
from tribench.harness.plan import Sequential, Sweep, plan
from tribench.workloads.spec import MeshSpec, PairSpec

KERNELS = ("moller_seed", "moller_trumbore", "curless", "woop_fma")
WORKLOADS = (PairSpec(n=256, hit_rate=0.2), MeshSpec("suzanne", triangles=100, width=8, height=8))
SETS = (("moller_seed", "moller_trumbore", "curless"), ("moller_seed", "woop_fma"))


def sweep(target: float = 1.0, budget_s: float = 600.0, processes: int = 16) -> Sweep:
    """Stages of 4 processes; a target so wide (within a factor 2) that every comparison is
    narrow once it may stop, after the second stage (stats.MIN_PROCESSES = 8)."""
    return Sweep(
        KERNELS,
        WORKLOADS,
        processes=processes,
        rounds=2,
        warmup=1,
        target_ms=0.2,
        rng_seed=3,
        workload_kernels=SETS,
        sequential=Sequential(stage=4, target=target, budget_s=budget_s),
    )


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    with pytest.MonkeyPatch.context() as mp:
        path = tmp_path_factory.mktemp("cache")
        mp.setenv("TRIBENCH_CACHE", str(path))
        yield path


@pytest.fixture(scope="module")
def finished(cache, tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("seq") / "run"
    runner.start(sweep(), run_dir, progress=False)
    return run_dir


@pytest.mark.slow  # a staged sweep (seconds)
def test_each_stage_runs_exactly_the_comparisons_still_wide(finished):
    record = stages.read_stages(finished)
    s = sweep()
    batches = runfolder.read_batches(finished)
    # two stages on a quiet machine; a loaded one's noise may keep a comparison open a stage longer
    assert record["end"] == "every comparison is within ±100%" and len(record["stages"]) >= 2
    for i, stage in enumerate(record["stages"]):
        assert (stage["first_process"], stage["stage"]) == (4 * i, i)
        ran = batches.loc[batches["process"].between(stage["first_process"], stage["last_process"])]
        assert set(ran["process"]) == set(range(stage["first_process"], stage["last_process"] + 1))
        assert {(w, k) for w, k in zip(ran["workload_id"], ran["kernel"], strict=True)} == {
            (w, k) for w, ks in stage["open"].items() for k in ks
        }
        before = batches.loc[batches["process"] < stage["first_process"]]
        references = dict.fromkeys(s.workload_ids, "moller_seed")
        narrow = stats.narrow_comparisons(stats.per_process(before), references, 1.0) if i else set()
        for wid, kernels in zip(s.workload_ids, SETS, strict=True):
            wide = [k for k in kernels if k != "moller_seed" and (wid, k) not in narrow]
            assert stage["open"].get(wid, []) == (["moller_seed", *wide] if wide else []), (i, wid)
    # the batches are keys of the plan, and not all of it: something stopped early
    assert set(runner.done_keys(finished)) < set(plan(s))
    # once the stages end, run.json says how many batches the run is (and the most it could have been)
    run = runfolder.read_run(finished)
    assert (run.n_batches, run.raw["n_batches_most"]) == (len(batches), len(plan(s)))


@pytest.mark.slow  # a staged sweep (seconds)
def test_the_stopped_comparisons_end_narrow_and_the_tables_pair_what_ran(finished, cache):
    result = analysed(finished, quick=True)
    spd = result.speedups
    record = stages.read_stages(finished)
    last = {(w, k) for w, ks in record["stages"][-1]["open"].items() for k in ks}
    for r in spd.itertuples(index=False):
        if (r.workload_id, r.kernel) not in last:  # stopped before the last stage: narrow then, and now
            assert r.n_processes >= stats.MIN_PROCESSES
    assert spd["n_processes"].nunique() >= 1 and spd["ratio"].notna().all()


@pytest.mark.slow  # a staged sweep (seconds)
def test_a_spent_budget_ends_the_sweep_after_its_first_stage(cache, tmp_path):
    runner.start(sweep(target=0.001, budget_s=0.01), tmp_path / "run", progress=False)
    record = stages.read_stages(tmp_path / "run")
    assert len(record["stages"]) == 1 and record["end"].startswith("the time budget")
    assert set(runfolder.read_batches(tmp_path / "run")["process"]) == {0, 1, 2, 3}


@pytest.mark.slow  # a staged sweep (seconds)
def test_a_sweep_cut_mid_stage_resumes_to_the_same_batches(finished, tmp_path):
    run_dir = tmp_path / "run"
    shutil.copytree(finished, run_dir)
    (run_dir / runfolder.LOCK).unlink(missing_ok=True)
    keys = set(runner.done_keys(finished))
    # cut the last stage's last process and the record of the end, as a kill would leave them
    record = stages.read_stages(run_dir)
    last = record["stages"][-1]["last_process"]
    batches = pd.read_csv(run_dir / runfolder.BATCHES)
    kept = batches.loc[batches["process"] != last]
    kept.to_csv(run_dir / runfolder.BATCHES, index=False)
    stages.write_stages(run_dir, {"stages": record["stages"], "end": None})
    run = runfolder.read_run(run_dir).raw
    runfolder.write_run(run_dir, {**run, "n_batches": run["n_batches_most"]})  # as it was before the end
    done = runner.resume(run_dir, progress=False)
    resumed = stages.read_stages(run_dir)
    after = runfolder.read_batches(run_dir)
    # the end is decided again on the re-timed process: on a loaded machine its noise may keep a
    # comparison open a stage longer (as in the first test), whose batches the resume then runs too
    extra = after.loc[after["process"] > last]
    assert done.batches_run == len(batches) - len(kept) + len(extra) and len(batches) > len(kept)
    assert resumed["stages"][: len(record["stages"])] == record["stages"]  # the stages as decided
    assert set(runner.done_keys(run_dir)) >= keys
    if extra.empty:  # the usual case: the same end, decided the same way
        assert set(runner.done_keys(run_dir)) == keys and resumed == record
        assert runfolder.read_run(run_dir).raw == runfolder.read_run(finished).raw


def test_an_ordinary_sweep_keeps_its_run_record_and_the_new_fields_round_trip():
    plain = Sweep(("moller_seed", "curless"), (PairSpec(n=10),))
    assert set(plain.to_dict()) == {
        "kernels",
        "workloads",
        "workload_ids",
        "processes",
        "rounds",
        "warmup",
        "target_ms",
        "rng_seed",
    }
    s = sweep()
    again = Sweep.from_dict(json.loads(json.dumps(s.to_dict())))
    assert again == s and plan(again) == plan(s)
    assert [again.kernels_for(w) for w in again.workloads] == [SETS[0], SETS[1]]


@pytest.mark.parametrize(
    "change, words",
    [
        ({"workload_kernels": (("moller_seed",),)}, "1 lists for 2 workloads"),
        ({"workload_kernels": (("moller_seed",), ("plucker",))}, "'plucker' is not one of the sweep's kernels"),
        ({"workload_kernels": ("moller_seed", "curless")}, "workload_kernels[0] must be a list"),
        ({"workload_kernels": ((), ("moller_seed",))}, "no kernel of the sweep runs mode"),
        ({"sequential": {"stage": 4}}, "sequential must be a Sequential design"),
    ],
)
def test_bad_kernel_sets_and_designs_are_user_errors(change, words):
    base = {"kernels": KERNELS, "workloads": WORKLOADS, "workload_kernels": SETS}
    with pytest.raises(UserError) as err:
        Sweep(**{**base, **change})
    assert words in str(err.value)


@pytest.mark.parametrize(
    "fields, words",
    [
        ({"stage": 0, "target": 0.02, "budget_s": 10}, "sequential.stage must be a positive"),
        ({"stage": 4, "target": 0.0, "budget_s": 10}, "sequential.target must be in (0, 1]"),
        ({"stage": 4, "target": 0.02, "budget_s": float("nan")}, "sequential.budget_s must be in"),
        ({"stage": 4, "target": "2%", "budget_s": 10}, "sequential.target must be a number"),
    ],
)
def test_bad_sequential_designs_are_user_errors(fields, words):
    with pytest.raises(UserError) as err:
        Sequential(**fields)
    assert words in str(err.value)
