"""An RNG seed is ``rng_seed`` since #52 ("seed" is the 2022 paper). What was written or typed with ``seed`` works
as before, and no workload id changes: old run folders and caches name their workloads by id."""

from __future__ import annotations

import inspect
import json
import re
import shutil
import warnings
from pathlib import Path

import pandas as pd
import pytest

import tribench
from tribench import cli
from tribench.cli.command import build_parser
from tribench.common import UserError
from tribench.harness import runfolder, runner
from tribench.harness.plan import default_sweep, plan
from tribench.harness.sweep_file import load_sweep_file
from tribench.workloads import cache
from tribench.workloads.kinds import spec_from_dict
from tribench.workloads.spec import MeshSpec, PairSpec, SeedSpec, workload_id

#: Ids computed on main at 1229c95, before the rename: a spec's id hashes the same bytes as then.
PINNED = [
    (PairSpec(), "pairs-7a9fc0e82fdd"),
    (PairSpec(n=4096, hit_rate=0.25, dtype="float32", winding="facing", rng_seed=7), "pairs-175044538539"),
    (MeshSpec("suzanne", triangles=968, width=48, height=48, dtype="float32", rng_seed=3), "mesh-e683994e9073"),
    (MeshSpec("suzanne", triangles=250_000, width=64, height=64, dtype="float32", accel="bvh"), "mesh-245c8209589a"),
    (MeshSpec("icosphere", rays="hit_rate", n_rays=100, rng_seed=2**63 - 1), "mesh-dc094f916843"),
    (SeedSpec("scene02", rays="shadow", sample=64, width=16, height=16, rng_seed=5), "seed-8c926e57fd84"),
]
#: The main job's workloads (``tribench run``, then ``--quick``), on main at 1229c95.
MAIN_JOB_IDS = {
    False: "pairs-39828f93718b pairs-ba114ab2046d pairs-07fbfdc68d51 pairs-ad45fe15c12a pairs-cf0e0d9f0629 "
    "pairs-5c37d705b958 pairs-e3d340e11831 pairs-b7fdfadc2cad pairs-a143422bc56e pairs-a0efa0d9a042 "
    "mesh-7d83416c18fb mesh-03983f0384a6 mesh-245c8209589a",
    True: "pairs-1638dcfbab0d pairs-8b51930e7077 pairs-35801482fe70 mesh-d7f39a28fb7c mesh-03f6c283ae6e "
    "mesh-9729c15e5742",
}


@pytest.mark.parametrize(("spec", "wid"), PINNED, ids=[w for _, w in PINNED])
def test_workload_ids_are_those_before_the_rename(spec, wid):
    assert workload_id(spec) == wid


@pytest.mark.parametrize("quick", [False, True])
def test_the_main_jobs_workload_ids_are_those_before_the_rename(quick):
    assert " ".join(default_sweep(quick).workload_ids) == MAIN_JOB_IDS[quick]


# --------------------------------------------------- what was written before: run folders, sweep files, caches

OLD_RUN = Path(__file__).parent / "data" / "run-before-rng-seed"  # written by main at 1229c95: "seed": 3
OLD_CACHE = Path(__file__).parent / "data" / "cache-before-rng-seed"  # its pairs workload, cached by main then


@pytest.fixture
def old_run(tmp_path, monkeypatch):
    """A copy of the old run folder, with a cache of its own holding the old cache file."""
    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path / "cache"))
    shutil.copytree(OLD_CACHE, tmp_path / "cache")
    return Path(shutil.copytree(OLD_RUN, tmp_path / "run", ignore=shutil.ignore_patterns("sweep.toml")))


def test_an_old_run_folder_reads_in_todays_names(old_run):
    assert '"seed": 3' in (old_run / "run.json").read_text()
    sweep = runfolder.read_run(old_run).sweep
    assert sweep.rng_seed == 3 and [w.rng_seed for w in sweep.workloads] == [3, 2]
    assert sweep.workload_ids == ("pairs-d94b86968420", "mesh-7e0a8ba8d113")  # checked against the recorded ids
    assert sweep.workloads[0] == PairSpec(n=64, hit_rate=0.5, rng_seed=3)


@pytest.mark.slow  # stats and report of a run (seconds)
def test_an_old_run_folder_gets_its_tables_and_report(old_run, monkeypatch, capsys):
    monkeypatch.chdir(old_run.parent)  # the fixture set the cache
    for command in ("stats", "report"):
        assert cli.main([command, str(old_run)]) == 0, capsys.readouterr().err
    assert set(tribench.load(old_run).estimates["workload_id"]) == {"pairs-d94b86968420", "mesh-7e0a8ba8d113"}
    toml = (old_run / "sweep.toml").read_text()  # the report's sweep file, in today's names
    assert "rng_seed = 3" in toml and not re.search(r"^seed =", toml, re.M)
    assert "<th>sweep RNG seed</th><td>3</td>" in (old_run / "report.html").read_text()


def test_an_old_cache_file_is_used_as_it_is(old_run):
    path = old_run.parent / "cache" / "pairs-d94b86968420.npz"
    before = path.read_bytes()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a rebuild warns
        assert cache.make(PairSpec(n=64, hit_rate=0.5, rng_seed=3)).spec == cache.load(path.stem).spec
    assert path.read_bytes() == before
    assert [c.problem for c in cache.list_cached()] == [None]


def test_a_run_interrupted_before_the_rename_resumes_exactly(old_run):
    for name in ("batches.csv", "processes.csv", "checks.csv"):  # stopped before process 1 started
        frame = pd.read_csv(old_run / name)
        frame.loc[frame["process"] == 0].to_csv(old_run / name, index=False)
    runner.resume(old_run, progress=False)
    run = runfolder.read_run(old_run)
    done = sorted(runner.done_keys(old_run, run))
    assert done == sorted(plan(run.sweep)) and len(done) == run.n_batches


def test_an_old_sweep_file_plans_the_same_batches():
    record = json.loads((OLD_RUN / "run.json").read_text())
    sweep = load_sweep_file(OLD_RUN / "sweep.toml")  # the report's sweep.toml on main: seed = 3
    assert sweep.rng_seed == 3 and sweep.workload_ids == tuple(record["sweep"]["workload_ids"])
    assert runner._plan_digest(plan(sweep)) == record["plan_sha256"]
    assert load_sweep_file(OLD_RUN / "sweep.toml", {"rng_seed": 4}).rng_seed == 4  # the flag still wins


# ------------------------------------------------------------------- both names at once: refused, never chosen


def test_both_names_in_a_sweep_file_are_refused(tmp_path):
    path = tmp_path / "both.toml"
    path.write_text((OLD_RUN / "sweep.toml").read_text().replace("seed = 3\n", "seed = 3\nrng_seed = 3\n", 1))
    with pytest.raises(UserError, match=f"^{re.escape(str(path))}: seed is the old name of rng_seed: give one"):
        load_sweep_file(path)


def test_both_names_in_a_run_folder_are_refused(old_run):
    record = json.loads((old_run / "run.json").read_text())
    record["sweep"]["workloads"][1]["rng_seed"] = 2
    (old_run / "run.json").write_text(json.dumps(record))
    with pytest.raises(UserError, match="'sweep' is not valid: seed is the old name of rng_seed"):
        runfolder.read_run(old_run)


@pytest.mark.parametrize(
    "make",
    [
        lambda: PairSpec(seed=1, rng_seed=2),
        lambda: spec_from_dict({"kind": "mesh", "seed": 1, "rng_seed": 1}),
        lambda: tribench.sweep(["moller_trumbore"], [PairSpec()], seed=1, rng_seed=1),
    ],
)
def test_both_names_in_python_are_refused(make):
    with pytest.raises(UserError, match="seed is the old name of rng_seed: give one of them"):
        make()


# ------------------------------------------------------------------------ what was typed before: keywords, flags


@pytest.mark.parametrize("cls", [PairSpec, MeshSpec, SeedSpec])
def test_a_spec_takes_seed_as_rng_seed_and_shows_rng_seed(cls):
    assert cls(seed=7) == cls(rng_seed=7) == spec_from_dict({"kind": cls.kind, "seed": 7})
    assert cls(rng_seed=7).to_dict()["rng_seed"] == 7 and "seed" not in cls().to_dict()
    assert "rng_seed" in inspect.signature(cls).parameters and "seed" not in inspect.signature(cls).parameters
    with pytest.warns(DeprecationWarning, match="rng_seed"):
        assert cls(rng_seed=7).seed == 7  # read as before, with a warning that names the new field


def test_tribench_sweep_takes_seed_as_rng_seed(monkeypatch, tmp_path):
    from tribench.harness.jobs import sweep as job

    def stop(sweep, *args, **kwargs):
        raise RuntimeError(sweep.rng_seed)

    monkeypatch.setattr(job, "run_sweep", stop)
    for given in ({"seed": 7}, {"rng_seed": 7}):
        with pytest.raises(RuntimeError, match="^7$"):
            tribench.sweep(["moller_trumbore"], [PairSpec(n=10)], out=tmp_path / "x", **given)


COMMANDS = [["sweep"], ["calibrate"], ["peers"], ["validate"], ["workloads", "make", "pairs"]]


@pytest.mark.parametrize("command", COMMANDS, ids=" ".join)
def test_seed_is_an_unlisted_spelling_of_rng_seed(command, capsys):
    parser = build_parser()
    assert [parser.parse_args([*command, flag, "3"]).rng_seed for flag in ("--seed", "--rng-seed")] == [3, 3]
    with pytest.raises(SystemExit):
        parser.parse_args([*command, "--help"])
    listed = capsys.readouterr().out
    assert "--rng-seed" in listed and "--seed" not in listed
    with pytest.raises(SystemExit) as stop:
        parser.parse_args([*command, "--rng-seed", "3", "--seed", "3"])
    error = capsys.readouterr().err
    assert stop.value.code == 2 and error.count("\n") == 1
    assert "argument --seed: the same flag as --rng-seed: give one" in error
