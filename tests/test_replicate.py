"""``tribench replicate``: a run's plan measured again, and each of its conclusions set beside the same here."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import pandas as pd
import pytest
from test_compare import steadied_pair
from test_report_run import run_fixture_dir

from tribench.harness import runfolder, runner
from tribench.harness.jobs.replicate import replication_plan
from tribench.reports import html as report_html
from tribench.reports.replication import replication_section, summary
from tribench.reports.rundata import load_run
from tribench.reports.tables.replication import WORDS, conclusions, word

SPEEDUP = 4.0  # the replication's curless: this much faster than the original's (about 2x slower than the baseline)


@pytest.mark.parametrize(
    ("original", "replicated", "expected"),
    [
        ("faster", "faster", "holds"),
        ("equivalent", "equivalent", "holds"),
        ("behind the fastest", "behind the fastest", "holds"),
        ("faster", "slower", "reversed"),
        ("equivalent", "faster", "reversed"),
        ("fastest", "behind the fastest", "reversed"),
        ("slower", "inconclusive", "now inconclusive"),
        ("fastest", "inconclusive", "now inconclusive"),
        ("inconclusive", "slower", "now decided"),
        ("inconclusive", "inconclusive", "still inconclusive"),
    ],
)
def test_each_pair_of_verdicts_gets_its_word(original, replicated, expected):
    assert word(original, replicated) == expected


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The session's run, steadied (the original), and the same with curless made 4x faster (the replication)."""
    with steadied_pair(tmp_path_factory, "curless", SPEEDUP) as pair:
        yield pair


def test_a_kernel_made_faster_reverses_its_conclusions_and_the_rest_keep_theirs(runs):
    a, b = (load_run(r) for r in runs)
    table = conclusions(a, b)
    assert list(table.columns) == list(runfolder.FILES[runfolder.REPLICATION]) and set(table["word"]) <= set(WORDS)
    kinds = set(table["conclusion"])
    assert kinds == {"against the baseline", "order of two", "place in its band"}
    involved = (table["kernel"] == "curless") | (table["other_kernel"] == "curless")
    # curless was about 2x slower than the baseline and moller_trumbore: 4x faster, it is now ahead of both
    assert (table.loc[involved & (table["conclusion"] != "place in its band"), "word"] == "reversed").all()
    band = table.loc[(table["conclusion"] == "place in its band") & (table["kernel"] == "curless")]
    assert not band.empty and (band["original_verdict"] == "behind the fastest").all()
    assert (band["replicated_verdict"] == "fastest").all() and (band["word"] == "reversed").all()
    # the others were measured the same: every verdict is the original's (their place in a band is curless's)
    same = table.loc[~involved & (table["conclusion"] != "place in its band")]
    assert not same.empty and (same["original_verdict"] == same["replicated_verdict"]).all()
    assert set(same["word"]) <= {"holds", "still inconclusive"}
    assert summary(table).startswith(f"Of {len(table)} conclusions of the original run: holds ")


@pytest.mark.slow  # a report (seconds)
def test_the_report_of_a_replication_opens_its_section_on_the_count_of_each_word(runs, tmp_path):
    a, b = (load_run(r) for r in runs)
    rep = tmp_path / "rep"
    shutil.copytree(runs[1], rep)
    record = json.loads((rep / runfolder.RUN).read_text())
    machine = {**a.machine, "cpu_model": "Some Other CPU"}
    record["replicates"] = {"run_dir": str(runs[0]), "run_id": a.run.run_id, "machine": machine, "left_out": []}
    (rep / runfolder.RUN).write_text(json.dumps(record))
    table = conclusions(a, b)
    runfolder.write_csv(table, rep / runfolder.REPLICATION)
    page = report_html.render(load_run(rep))
    section = page[page.index('<section id="replication"') :]
    section = section[: section.index("</section>")]
    assert summary(table) in section and "Some Other CPU →" in section
    assert section.index("reversed") < section.index("still inconclusive")  # the worst news first
    assert page.index('id="replication"') < page.index('id="headline"')  # right after the answer
    assert replication_section(b) == ""  # a run that replicates nothing has no such section


def test_the_plan_leaves_out_a_missing_compiler_and_says_so(tmp_path_factory, tmp_path, monkeypatch):
    measured, cache = run_fixture_dir(tmp_path_factory)
    copy = tmp_path / "run"
    shutil.copytree(measured, copy)
    monkeypatch.setenv("TRIBENCH_CACHE", str(cache))
    record = json.loads((copy / runfolder.RUN).read_text())
    sweep, notes, _ = replication_plan(copy)
    assert sweep.kernels == tuple(record["sweep"]["kernels"]) and notes == []
    assert [s.to_dict() for s in sweep.workloads] == record["sweep"]["workloads"]
    assert (sweep.processes, sweep.rounds, sweep.rng_seed) == tuple(
        record["sweep"][k] for k in ("processes", "rounds", "rng_seed")
    )
    record["sweep"] |= {"builds": ["installed", "no-such-cc -O2"], "processes": 4}  # a build needs two processes
    record["process_seeds"] = [*record["process_seeds"], 12345]
    (copy / runfolder.RUN).write_text(json.dumps(record))
    sweep, notes, _ = replication_plan(copy)
    assert sweep.builds == ("installed",) and len(notes) == 1 and "no compiler 'no-such-cc'" in notes[0]


@pytest.mark.slow
def test_tribench_replicate_reruns_a_copied_run_with_an_empty_cache(tmp_path_factory, tmp_path):
    measured, _ = run_fixture_dir(tmp_path_factory)
    copy = tmp_path / "elsewhere"
    shutil.copytree(measured, copy)
    env_cache = tmp_path / "empty-cache"
    out = tmp_path / "rep"
    kwargs = {"capture_output": True, "text": True, "env": {**os.environ, "TRIBENCH_CACHE": str(env_cache)}}
    done = subprocess.run(
        [sys.executable, "-m", "tribench.cli", "replicate", str(copy), "--out", str(out), "--no-progress"], **kwargs
    )
    assert done.returncode == 0, done.stderr
    table = pd.read_csv(out / runfolder.REPLICATION)
    assert summary(table) in done.stdout and len(table) > 0
    original, new = (json.loads((d / runfolder.RUN).read_text()) for d in (copy, out))
    assert new["sweep"]["workload_ids"] == original["sweep"]["workload_ids"]  # the same workloads, by spec and RNG seed
    assert new["replicates"]["run_id"] == original["run_id"]
    assert 'id="replication"' in (out / runfolder.REPORT).read_text(encoding="utf-8")
    again = subprocess.run(
        [sys.executable, "-m", "tribench.cli", "replicate", str(copy), "--resume", str(out)], **kwargs
    )  # a finished replication: nothing more to measure, the comparison made again
    assert again.returncode == 0 and summary(table) in again.stdout, again.stderr
    refused = subprocess.run(
        [sys.executable, "-m", "tribench.cli", "replicate", str(copy), "--resume", str(copy)], **kwargs
    )
    assert refused.returncode == 2 and refused.stderr.endswith(f"{copy} is no replication of {copy}\n")


def test_an_interrupted_replication_names_its_own_way_to_finish(tmp_path):
    out = tmp_path / "rep"
    with pytest.raises(runner.SweepInterrupted) as caught:
        with runner.resumed_with(out, f"tribench replicate RUN --resume {out}"):
            raise runner.SweepInterrupted(
                f"interrupted: 3 of 9 batches saved; finish with: tribench sweep --resume {out}"
            )
    assert str(caught.value) == f"interrupted: 3 of 9 batches saved; finish with: tribench replicate RUN --resume {out}"


@pytest.mark.slow
def test_a_known_truth_replicates_twice_the_work_stays_slower_and_an_aa_pair_never_reverses(tmp_path, monkeypatch):
    from tribench.harness.jobs import replicate
    from tribench.harness.jobs.sweep import run_sweep
    from tribench.harness.plan import Sweep
    from tribench.reports import tables
    from tribench.workloads.spec import PairSpec

    monkeypatch.setenv("TRIBENCH_CACHE", str(tmp_path / "cache"))
    # the baseline, an A/A pair (the same code under two names) and a kernel that does twice the work
    kernels = ("moller_seed", "moller_trumbore", "moller_trumbore_same", "moller_trumbore_twice")
    sweep = Sweep(kernels, (PairSpec(n=2000, hit_rate=0.5),), processes=8, rounds=7, warmup=1, target_ms=2)
    original, replicated = tmp_path / "a", tmp_path / "b"
    run_sweep(sweep, original, say=lambda line: None, progress=False)
    tables.write_all(original, baseline="moller_seed")
    replicate.measure(original, replicated, say=lambda line: None, progress=False)
    tables.write_all(replicated, baseline="moller_seed")
    table = conclusions(load_run(original), load_run(replicated))
    twice = table.loc[(table["kernel"] == "moller_trumbore_twice") & (table["conclusion"] == "against the baseline")]
    assert len(twice) == 1 and (twice["original_ratio"] < 1).all() and (twice["replicated_ratio"] < 1).all()
    # no test asserts a speed on a shared machine: quiet, twice the work is "slower" in both runs and "holds", but
    # at load 4.5 one run's interval reached across 1 at 6 processes x 7 rounds; what no load may do is decide it
    # the other way
    verdicts = {*twice["original_verdict"], *twice["replicated_verdict"]}
    assert verdicts <= {"slower", "inconclusive"} and "reversed" not in set(twice["word"])
    pair = {"moller_trumbore", "moller_trumbore_same"}
    twin = table.loc[[{k, o} == pair for k, o in zip(table["kernel"], table["other_kernel"], strict=True)]]
    assert not twin.empty and "reversed" not in set(twin["word"])
